#!/usr/bin/env bash
# Configures and builds PortaSLAM (Release, Ninja) into ./build, or into $PORTA_BUILD_DIR.
# Extra arguments go to CMake, e.g. `bash ci/build.sh -DPORTA_WITH_VULKAN=OFF`.
# Run ci/setup.sh first to install the dependencies.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

build_dir="${PORTA_BUILD_DIR:-build}"
jobs="${PORTA_JOBS:-2}"

cmake -S . -B "$build_dir" -G Ninja -DPORTA_WERROR=ON "$@"
cmake --build "$build_dir" -j "$jobs"
echo "build: done; the program is $build_dir/apps/portaslam"
