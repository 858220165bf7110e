#!/usr/bin/env bash
# Configures (Ninja, warnings as errors), builds and runs every test: unit, quality, CLI, fuzz
# (the plain driver) and equivalence; then the aarch64 job (ci/cross-aarch64.sh: the cross build
# for the Jetson's CPU, its unit and SLAM tests under qemu-aarch64, and the cpu frontend's output
# compared with this build's, byte for byte); then the sanitizer runs (ci/sanitize.sh: ASan +
# UBSan with the fuzz targets' plain driver, TSan) and the short libFuzzer run (ci/fuzz.sh: 20 000
# executions per target, fixed seed, about a minute after its build). Exits non-zero when a build
# or any test fails. Build folder: ./build, or $PORTA_BUILD_DIR. Extra arguments go to CMake.
# Between ctest and the aarch64 job, ci/python-package.sh installs the Python package with pip
# and tests it. PORTA_PYTHON_PACKAGE=off skips that, PORTA_CROSS=off the aarch64 job,
# PORTA_SANITIZERS=off the sanitizer and libFuzzer runs (all off: a quick local check; CI runs them).
# Run ci/setup.sh first to install the dependencies.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

build_dir="${PORTA_BUILD_DIR:-build}"
jobs="${PORTA_JOBS:-2}"

# ci/setup.sh installs PoCL (OpenCL) and lavapipe (Vulkan) on the CPU: their equivalence runs
# must happen, so a backend that cannot run fails instead of being skipped.
export PORTA_EQUIVALENCE_REQUIRE="${PORTA_EQUIVALENCE_REQUIRE:-opencl,vulkan}"

# The Python module is built for, and its tests (ctest -L python) run in, the venv of
# ci/python-env.sh (Debian's python3, numpy and pytest, and plyfile).
python_env="$(bash ci/python-env.sh "$build_dir/python-env")"

cmake -S . -B "$build_dir" -G Ninja -DPORTA_WERROR=ON -DPORTA_BUILD_PYTHON=ON \
      -DPython_EXECUTABLE="$python_env/bin/python" "$@"
cmake --build "$build_dir" -j "$jobs"
ctest --test-dir "$build_dir" --output-on-failure --no-tests=error -j "$jobs"

# The Python package as a user installs it (`pip install .` into a fresh venv, then tests/python
# against it).
if [ "${PORTA_PYTHON_PACKAGE:-on}" != off ]; then
  bash ci/python-package.sh
fi

# The product runs on aarch64 boards: the same tests there, and the same features as this build's.
if [ "${PORTA_CROSS:-on}" != off ]; then
  PORTA_X86_BUILD_DIR="$build_dir" bash ci/cross-aarch64.sh
fi

# The fuzz targets run in ctest above and under ASan + UBSan in ci/sanitize.sh (the plain driver:
# seeds and deterministic mutations), then with libFuzzer's coverage-guided mutations.
if [ "${PORTA_SANITIZERS:-on}" != off ]; then
  bash ci/sanitize.sh
  bash ci/fuzz.sh
fi
