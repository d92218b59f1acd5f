#!/usr/bin/env bash
# `make docker-build`: builds the gvd image from docker/Dockerfile and smoke-tests it, on a
# machine with no container daemon and no registry (ENVIRONMENT.md, Containers): the
# debian:bookworm-slim base is made locally with debootstrap from the configured Debian mirror
# and imported into podman (vfs storage, chroot isolation); the smoke test runs the built image
# with `buildah run`: `gvd --version`, a small `gvd compute`, and gvd-server answering /readyz.
# Needs root and the packages podman, buildah, debootstrap (installed here when missing).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
image=${GVD_IMAGE:-localhost/gvd:latest}
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
  echo "docker-build: importing the local base image $base"
  tar -C "$rootfs" -c . | podman "${storage[@]}" import - "$base"
fi

start=$(date +%s)
podman "${storage[@]}" build --isolation chroot --pull=never -f "$root/docker/Dockerfile" \
  -t "$image" "$root"
echo "docker-build: image $image built in $(( $(date +%s) - start )) s"
podman "${storage[@]}" image ls "$image"

echo "docker-build: smoke test"
ctr=$(buildah "${storage[@]}" from "$image")
trap 'buildah "${storage[@]}" rm "$ctr" >/dev/null 2>&1 || true' EXIT
run() { buildah "${storage[@]}" run --isolation chroot --user gvd "$ctr" -- "$@"; }
run /usr/local/bin/gvd --version
run /usr/local/bin/gvd compute /usr/local/share/gvd/examples/gears2d.json -q \
  --graph /tmp/graph.json
run sh -c 'test -s /tmp/graph.json && echo "gvd compute: graph.json written"'
run sh -c '/usr/local/bin/gvd-server --port 18080 --store /tmp/store --quiet & pid=$!;
  for i in $(seq 50); do curl -fsS http://127.0.0.1:18080/readyz && break; sleep 0.2; done;
  echo; curl -fsS http://127.0.0.1:18080/ | grep -c "<script" | sed "s/^/viewer page scripts: /";
  kill $pid; wait $pid'
echo "docker-build: ok"
