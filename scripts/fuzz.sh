#!/usr/bin/env bash
# Runs one libFuzzer harness for longer, growing its corpus in build-fuzz/fuzz-corpus/NAME.
#   scripts/fuzz.sh NAME [SECONDS]      e.g. scripts/fuzz.sh glb 600
# NAME: obj off ply stl gltf glb drc (the readers, then preparation and a short line) or json
# (the feature-line options mapping). Builds build-fuzz/ first (clang, libFuzzer, ASan+UBSan).
# A crashing input lands in build-fuzz/fuzz-artifacts/; keep it as tests/fuzz/corpus/NAME/regression_*.
set -euo pipefail
cd "$(dirname "$0")/.."
name=${1:?usage: scripts/fuzz.sh NAME [SECONDS]}
seconds=${2:-300}
build=${BUILD_DIR:-build-fuzz}
BUILD_DIR=$build scripts/setup.sh -DCMAKE_CXX_COMPILER=clang++ -DFEATURELINE_FUZZ=ON -DFEATURELINE_SANITIZE=ON \
  -DFEATURELINE_BUILD_BENCH=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS=-fsanitize=fuzzer-no-link
fuzzer="$build/tests/fuzz/fuzz_read_$name"
[ "$name" = json ] && fuzzer="$build/tests/fuzz/fuzz_feature_line_json"
mkdir -p "$build/fuzz-corpus/$name"
RUNS=-1 KEEP_CORPUS="$build/fuzz-corpus/$name" ARTIFACTS="$build/fuzz-artifacts" \
  bash tests/fuzz/run_fuzzer.sh "$fuzzer" "$name" "$seconds"
