#!/usr/bin/env bash
# The container files without building an image (make test; `make docker-build` builds it):
# dockerfilelint (npm, docker/lint) finds no issue in docker/Dockerfile, everything the
# Dockerfile COPYs from the build context and every script it runs exists, and compose.yaml
# points at the Dockerfile.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
lint=docker/lint/node_modules/.bin/dockerfilelint
if [ ! -x "$lint" ]; then
  echo "check-dockerfile: $lint missing (docker/install-deps.sh runs npm ci in docker/lint)" >&2
  exit 1
fi
"$lint" docker/Dockerfile
status=0
# COPY sources from the context (not --from=stage): every argument but the last.
while read -r line; do
  set -- $line
  shift  # COPY
  args=()
  for a in "$@"; do case "$a" in --*) ;; *) args+=("$a") ;; esac; done
  n=${#args[@]}
  for ((i = 0; i < n - 1; i++)); do
    if [ ! -e "${args[$i]}" ]; then
      echo "check-dockerfile: COPY source ${args[$i]} does not exist" >&2
      status=1
    fi
  done
done < <(grep -E '^COPY ' docker/Dockerfile | grep -v -- '--from=')
for script in $(grep -oE '\./docker/[A-Za-z0-9_.-]+' docker/Dockerfile | sort -u); do
  if [ ! -x "$script" ]; then
    echo "check-dockerfile: $script (run by the Dockerfile) is missing or not executable" >&2
    status=1
  fi
done
if ! grep -q 'dockerfile: docker/Dockerfile' docker/compose.yaml; then
  echo "check-dockerfile: docker/compose.yaml does not build docker/Dockerfile" >&2
  status=1
fi
if [ ! -f .dockerignore ] || ! grep -qx 'build' .dockerignore; then
  echo "check-dockerfile: .dockerignore must keep build/ out of the context" >&2
  status=1
fi
[ $status -eq 0 ] && echo "check-dockerfile: ok"
exit $status
