#!/usr/bin/env bash
# Installs every build, test and benchmark dependency of gvd from Debian packages (and the
# npm registry for the JavaScript test tools). Idempotent: installs only what is missing.
# Used by `make run`, `make test`, CI and docker/. Needs root (or sudo) for apt-get.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config ccache git
  libcpp-httplib-dev libssl-dev nlohmann-json3-dev libtinygltf-dev
  opencl-headers opencl-clhpp-headers ocl-icd-opencl-dev ocl-icd-libopencl1 pocl-opencl-icd clinfo
  libgtest-dev libgmock-dev libbenchmark-dev libboost-dev wrk curl python3
  clang-format clang-tidy
  chromium
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done
# Node.js + npm: any installed node with npm will do (Debian's nodejs + npm otherwise).
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
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

# JavaScript: three.js for the web viewer (clients/web, copied into the build) and the test
# tools (glTF and OpenAPI validators, playwright-core for the browser test) in tests/js, each
# pinned by its package-lock.json. `npm ci` again whenever a lock file is newer than the install.
here=$(cd "$(dirname "$0")/.." && pwd)
for dir in "$here/clients/web" "$here/tests/js"; do
  [ -f "$dir/package-lock.json" ] || continue
  if [ ! -f "$dir/node_modules/.package-lock.json" ] ||
     [ "$dir/package-lock.json" -nt "$dir/node_modules/.package-lock.json" ]; then
    echo "install-deps: npm ci in ${dir#"$here"/}"
    (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error)
  fi
done
