#!/usr/bin/env bash
# Every test: a Release build with warnings, then the same tests under AddressSanitizer and
# UndefinedBehaviorSanitizer, then the libFuzzer harnesses (a clang build). Prints ctest's
# summary line for each.
set -euo pipefail
cd "$(dirname "$0")/.."
export FEATURELINE_TEST_TOOLS=1
scripts/setup.sh
status=0
echo "== ctest (Release)"
# The image test (label image) builds docker/'s images from the sources with podman and runs
# them (tests/integration/image_test.sh, about 10-15 minutes on 2 cores the first time);
# FEATURELINE_IMAGE_TESTS=0 leaves it out of a quick run.
image_tests=()
if [ "${FEATURELINE_IMAGE_TESTS:-1}" = 0 ]; then image_tests=(-LE image); fi
ctest --test-dir "${BUILD_DIR:-build}" --output-on-failure -j "$(nproc)" "${image_tests[@]}" || status=1
echo "== ctest (ASan + UBSan)"
BUILD_DIR=build-sanitize scripts/setup.sh -DFEATURELINE_SANITIZE=ON -DFEATURELINE_BUILD_BENCH=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo
# The browser tests run once, against the Release server (they drive Chromium, not our code);
# the first-contact tests run scripts/run.sh and the installed programs, which are Release builds;
# the image test builds the image from the sources, whatever the build tree; the orchestration
# tests (the cluster's nginx and Redis, the deploy files, the answers against the OpenAPI
# contract) exercise the same server code as integration.server and integration.store, which do run here.
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-sanitize --output-on-failure -j "$(nproc)" -LE "web|first_contact|image|orchestration" || status=1
echo "== fuzzing (libFuzzer + ASan + UBSan): every harness over its seeds and a fixed number of mutations"
# scripts/fuzz.sh NAME SECONDS runs one harness for longer.
BUILD_DIR=build-fuzz scripts/setup.sh -DCMAKE_CXX_COMPILER=clang++ -DFEATURELINE_FUZZ=ON -DFEATURELINE_SANITIZE=ON \
  -DFEATURELINE_BUILD_BENCH=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS=-fsanitize=fuzzer-no-link
ctest --test-dir build-fuzz --output-on-failure -j "$(nproc)" || status=1
exit $status
