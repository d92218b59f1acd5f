#!/usr/bin/env bash
# Runs every libFuzzer target of a GVD_FUZZ=ON build for a while (`make fuzz`):
#   tests/fuzz/run_fuzz.sh BUILD_DIR SECONDS_PER_TARGET
# Each target grows its own corpus in BUILD_DIR/fuzz-corpus/<name> from the seeds (the test
# data, tests/fuzz/seeds and every past finding in tests/fuzz/crashes); an input that crashes,
# trips ASan/UBSan, leaks, runs over 10 s or over 2 GB is written to
# tests/fuzz/crashes/<name>/ (commit it: `make test` replays it from then on). Exit 1 when
# any target found something.
set -uo pipefail
build=${1:?build directory}
seconds=${2:-60}
here=$(cd "$(dirname "$0")" && pwd)
list="$build/fuzz_targets.txt"
[ -f "$list" ] || { echo "run_fuzz: $list missing (configure with -DGVD_FUZZ=ON)" >&2; exit 2; }
read -r -a names < <(sed -n 1p "$list")
read -r -a seeds < <(sed -n 2p "$list")
failed=()
for name in "${names[@]}"; do
  corpus="$build/fuzz-corpus/$name"
  crashes="$here/crashes/$name"
  mkdir -p "$corpus" "$crashes"
  echo "== fuzz_$name: $seconds s"
  if ! "$build/tests/fuzz/fuzz_$name" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
      -print_final_stats=1 -artifact_prefix="$crashes/" "$corpus" "${seeds[@]}" \
      > "$build/fuzz-$name.log" 2>&1; then
    failed+=("$name")
    echo "   FOUND something: $build/fuzz-$name.log, inputs in tests/fuzz/crashes/$name/"
  fi
  grep -E '^stat::(number_of_executed_units|new_units_added)' "$build/fuzz-$name.log" | sed 's/^/   /'
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "run_fuzz: findings in ${failed[*]}"
  exit 1
fi
echo "run_fuzz: ${#names[@]} targets, $seconds s each, nothing found"
