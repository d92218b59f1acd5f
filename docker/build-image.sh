#!/usr/bin/env bash
# `make docker-build`: builds the gvd image from docker/Dockerfile and smoke-tests it, on a
# machine with no container daemon and no registry (as this project's build machines are): the
# debian:bookworm-slim base is made locally with debootstrap from the configured Debian mirror
# and imported into podman (vfs storage, chroot isolation); the smoke test runs the built image
# with `buildah run`: `gvd --version`, a small `gvd compute`, and gvd-server answering /readyz.
# Needs root and the packages podman, buildah, debootstrap (installed here when missing).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
# GVD_OPENCL=0: the image without PoCL (docker/Dockerfile, GVD_RUNTIME=runtime-cpu).
opencl=${GVD_OPENCL:-1}
if [ "$opencl" = 0 ]; then
  image=${GVD_IMAGE:-localhost/gvd:cpu}
  runtime=runtime-cpu
else
  image=${GVD_IMAGE:-localhost/gvd:latest}
  runtime=runtime
fi
base=docker.io/library/debian:bookworm-slim
storage=(--storage-driver vfs)

if [ "$(id -u)" -ne 0 ]; then
  echo "docker-build: needs root (podman with vfs storage and chroot isolation)" >&2
  exit 1
fi
need=()
for tool in podman buildah debootstrap; do command -v "$tool" >/dev/null || need+=("$tool"); done
if [ ${#need[@]} -gt 0 ]; then
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends podman buildah debootstrap
fi

if ! podman "${storage[@]}" image exists "$base"; then
  rootfs=${GVD_ROOTFS:-/var/tmp/gvd-rootfs}
  mirror=${GVD_DEBIAN_MIRROR:-$(sed -n 's/^URIs: *//p' /etc/apt/sources.list.d/debian.sources 2>/dev/null | head -1)}
  mirror=${mirror:-http://deb.debian.org/debian}
  if [ ! -x "$rootfs/bin/sh" ]; then
    echo "docker-build: debootstrap bookworm into $rootfs from $mirror"
    debootstrap --variant=minbase bookworm "$rootfs" "$mirror"
  fi
  # Machines behind a TLS-intercepting proxy trust its CA locally (npm fetches three.js over
  # https in the build stage): the base made here trusts the same extra CAs.
  if compgen -G "/usr/local/share/ca-certificates/*.crt" >/dev/null; then
    mkdir -p "$rootfs/usr/local/share/ca-certificates"
    cp /usr/local/share/ca-certificates/*.crt "$rootfs/usr/local/share/ca-certificates/"
  fi
  # As Debian's own bookworm-slim: no downloaded packages nor package lists in the base
  # (debootstrap keeps the ~140 MB of .deb files it installed, and apt's caches ~80 MB).
  rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/cache/apt/*.bin \
    "$rootfs"/var/lib/apt/lists/*
  echo "docker-build: importing the local base image $base"
  tar -C "$rootfs" -c . | podman "${storage[@]}" import - "$base"
fi

start=$(date +%s)
# The docker format, not podman's default OCI: OCI images have no HEALTHCHECK (podman drops it
# with a warning), and compose and Swarm read it from the image.
podman "${storage[@]}" build --format docker --isolation chroot --pull=never \
  --build-arg GVD_RUNTIME="$runtime" -f "$root/docker/Dockerfile" -t "$image" "$root"
echo "docker-build: image $image built in $(( $(date +%s) - start )) s"
podman "${storage[@]}" image ls "$image"
health=$(podman "${storage[@]}" image inspect --format '{{json .Config.Healthcheck}}' "$image")
echo "docker-build: health check $health"
case "$health" in
  *healthz*) ;;
  *) echo "docker-build: the image carries no HEALTHCHECK (built as OCI?)" >&2; exit 1 ;;
esac

echo "docker-build: smoke test"
ctr=$(buildah "${storage[@]}" from "$image")
trap 'buildah "${storage[@]}" rm "$ctr" >/dev/null 2>&1 || true' EXIT
run() { buildah "${storage[@]}" run --isolation chroot --user gvd "$ctr" -- "$@"; }
run /usr/local/bin/gvd --version
run /usr/local/bin/gvd compute /usr/local/share/gvd/examples/gears2d.json -q \
  --graph /tmp/graph.json
run sh -c 'test -s /tmp/graph.json && echo "gvd compute: graph.json written"'
# PoCL compiles the kernels in the container (its clang and linker): an image slimmed too far
# fails here, not at the first user's job.
if [ "$opencl" = 0 ]; then
  # No OpenCL platform: auto runs the CPU twins and says why.
  run sh -c '/usr/local/bin/gvd compute /usr/local/share/gvd/examples/balls_on_plate.json \
    --backend auto --graph /tmp/graph3.json 2>/tmp/cpu.log; status=$?; grep backend /tmp/cpu.log
    test $status -eq 0 && test -s /tmp/graph3.json && echo "gvd compute --backend auto: ok (CPU)"'
else
run sh -c 'POCL_CACHE_DIR=/tmp/pocl /usr/local/bin/gvd compute \
  /usr/local/share/gvd/examples/balls_on_plate.json --backend opencl --graph /tmp/graph3.json \
  2>/tmp/opencl.log; status=$?; grep backend /tmp/opencl.log; test $status -eq 0 &&
  test -s /tmp/graph3.json && echo "gvd compute --backend opencl: ok"'
fi
run sh -c '/usr/local/bin/gvd-server --port 18080 --store /tmp/store --quiet & pid=$!;
  for i in $(seq 50); do curl -fsS http://127.0.0.1:18080/readyz && break; sleep 0.2; done;
  echo; curl -fsS http://127.0.0.1:18080/ | grep -c "<script" | sed "s/^/viewer page scripts: /";
  kill $pid; wait $pid'
echo "docker-build: what takes the room (MB on disk; dpkg's sizes would count what dpkg-slim.cfg left out)"
run sh -c 'du -xsm /usr/lib/llvm-15 /usr/share/pocl /usr/lib/x86_64-linux-gnu /usr/lib/gcc /usr/include \
  /usr/share /usr/bin /usr/local /var 2>/dev/null | sed "s/^/  /";
  echo "  largest in /usr/lib/x86_64-linux-gnu:";
  du -xsm /usr/lib/x86_64-linux-gnu/* 2>/dev/null | sort -rn | head -8 | sed "s/^/    /"'
echo "docker-build: ok"
