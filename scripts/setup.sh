#!/usr/bin/env bash
# Installs what Featureline needs, only what is missing (idempotent): Debian packages with
# apt-get, the npm packages of package.json with npm; then configures and builds into build/
# (or $BUILD_DIR) with the given extra CMake arguments.
#   scripts/setup.sh [cmake args...]
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(g++ cmake ninja-build pkg-config git ca-certificates
  libopenmesh-dev libeigen3-dev libcpp-httplib-dev nlohmann-json3-dev libtinygltf-dev libdraco-dev
  libgtest-dev libcli11-dev jq curl zlib1g-dev libnanoflann-dev libhiredis-dev help2man)
# What only the tests use (scripts/test.sh sets FEATURELINE_TEST_TOOLS=1): the browser, the
# cluster's nginx and Redis, the deployment files' YAML check, ss for free ports, what CPack
# reads the .deb's dependencies with (dpkg-shlibdeps, file), the independent readers the
# export formats are read back with (meshio, Open3D, VTK), what the images are built and run
# with (podman; debootstrap for their base when no registry has debian:12).
if [ "${FEATURELINE_TEST_TOOLS:-0}" = 1 ]; then
  packages+=(chromium nginx redis-server python3-yaml iproute2 dpkg-dev file python3-meshio python3-open3d python3-vtk9
    podman debootstrap)
fi
# The fuzz build (scripts/test.sh, scripts/fuzz.sh) compiles with clang and links libFuzzer.
case " $* " in *clang*) packages+=(clang libclang-rt-14-dev) ;; esac
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# Node.js runs the contract and glTF validators; any installed node and npm will do.
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then missing+=(nodejs npm); fi
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  if [ "$(id -u)" != 0 ]; then sudo=sudo; else sudo=; fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
if [ ! -f node_modules/.package-lock.json ] || [ package-lock.json -nt node_modules/.package-lock.json ]; then
  echo "setup: npm ci"
  scripts/npm-ci.sh
fi

build=${BUILD_DIR:-build}
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build "$build" -j "$(nproc)"
