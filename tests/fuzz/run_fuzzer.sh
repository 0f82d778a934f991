#!/usr/bin/env bash
# Runs one libFuzzer harness over its seed corpus, then a fixed number of mutations.
#   tests/fuzz/run_fuzzer.sh FUZZER CORPUS [SECONDS]
# CORPUS names tests/fuzz/corpus/CORPUS/ and, for mesh formats, the shared meshes of that
# extension up to 64 KB ($SHARED/data/meshes, default ../shared beside the repository).
# Environment: RUNS (mutations and seeds together, default 3000; -1 with SECONDS for a time
# bound only), ARTIFACTS (where a crashing input is written, default ./fuzz-artifacts),
# KEEP_CORPUS=DIR (grow the corpus in DIR and keep it, for long runs; default: a temporary copy).
# Exits non-zero, with the reproducer's path, when the harness finds anything.
set -euo pipefail
fuzzer=$1 corpus=$2 seconds=${3:-60}
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
shared=${SHARED:-$root/../shared}
artifacts=${ARTIFACTS:-$PWD/fuzz-artifacts}
[ -x "$fuzzer" ] || { echo "FAIL no fuzzer binary at $fuzzer"; exit 1; }
[ -d "$root/tests/fuzz/corpus/$corpus" ] || { echo "FAIL no seed corpus tests/fuzz/corpus/$corpus"; exit 1; }

work=$(mktemp -d "${TMPDIR:-/tmp}/featureline-fuzz.XXXXXX")
trap 'rm -rf "$work"' EXIT
dir=${KEEP_CORPUS:-$work/corpus}
mkdir -p "$dir" "$artifacts"
cp "$root/tests/fuzz/corpus/$corpus"/* "$dir/"
if [ "$corpus" != json ]; then
  [ -d "$shared/data/meshes" ] || { echo "FAIL missing $shared/data/meshes (set SHARED=...)"; exit 1; }
  find "$shared/data/meshes" -maxdepth 1 -type f -iname "*.$corpus" -size -64k -exec cp {} "$dir/" \;
fi
echo "# $(basename "$fuzzer"): $(ls "$dir" | wc -l) seeds, ${RUNS:-3000} runs, at most $seconds s"
# -seed fixes the mutations; -timeout flags a hang; -rss_limit_mb flags an input that takes
# memory, -malloc_limit_mb one allocation far past the harness's 4 MiB account.
"$fuzzer" -seed=1 -runs="${RUNS:-3000}" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=64 \
  -max_len=65536 -print_final_stats=1 -artifact_prefix="$artifacts/$(basename "$fuzzer")-" "$dir" 2>"$work/log" || {
  status=$?
  tail -n 60 "$work/log"
  echo "FAIL $(basename "$fuzzer") exited with $status; reproducer in $artifacts (run: $fuzzer FILE)"
  exit 1
}
grep -E '^stat::number_of_executed_units|^Done' "$work/log" || true
echo "ok   $(basename "$fuzzer")"
