#!/usr/bin/env bash
# Sanitizer runs (docs/RELIABILITY.md): builds PortaSLAM twice more and runs
#  1. the unit, slam and cli tests under AddressSanitizer + UndefinedBehaviorSanitizer
#     (build-asan; halt_on_error, leaks checked), and
#  2. the threaded tests (local mapping, loop closing, relocalisation, tracking, the cpu backend's
#     thread pool, frames in flight, the parallel renderer and dataset loads) under
#     ThreadSanitizer (build-tsan).
# The GPU backends are left out of these builds: lavapipe and PoCL are not instrumented (their
# own leaks and races would be reported as ours), and the equivalence suite runs them in the
# main build. Exits non-zero on the first report. Called by ci/test.sh; PORTA_SANITIZERS=off there
# skips it. Run ci/setup.sh first.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

jobs="${PORTA_JOBS:-2}"
# Warnings are errors in the main build; with sanitizers GCC warns falsely (-Wmaybe-uninitialized
# inside <regex> at -O1), so here they are only warnings.
common=(-G Ninja -DPORTA_WERROR=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1"
        -DPORTA_WITH_VULKAN=OFF -DPORTA_WITH_OPENCL=OFF -DPORTA_WITH_CUDA=OFF)

# These builds have no GPU backend by design: tests that compare backends skip them, saying so,
# instead of failing for a backend that ci/test.sh requires of the main build.
unset PORTA_EQUIVALENCE_REQUIRE

export ASAN_OPTIONS="halt_on_error=1:abort_on_error=0:detect_leaks=1:strict_string_checks=1:detect_stack_use_after_return=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/ci/tsan.supp"

if [ "${PORTA_SANITIZE_ONLY:-all}" != thread ]; then
  asan_dir="${PORTA_ASAN_BUILD_DIR:-build-asan}"
  echo "sanitize: ASan + UBSan build in $asan_dir"
  cmake -S . -B "$asan_dir" "${common[@]}" -DPORTA_SANITIZE=address,undefined
  # Only what the unit, slam, cli and fuzz tests run (not the equivalence or quality suites).
  cmake --build "$asan_dir" -j "$jobs" --target portaslam porta_place_bench porta_unit_tests porta_no_opencv_tests porta_slam_tests \
    porta_fuzz_make_seeds porta_fuzz_png porta_fuzz_settings porta_fuzz_trajectory porta_fuzz_kitti \
    porta_fuzz_euroc porta_fuzz_map_file
  ctest --test-dir "$asan_dir" --output-on-failure --no-tests=error -j "$jobs" -L "^(unit|slam|cli|fuzz)$"
fi

if [ "${PORTA_SANITIZE_ONLY:-all}" != address ]; then
  tsan_dir="${PORTA_TSAN_BUILD_DIR:-build-tsan}"
  echo "sanitize: TSan build in $tsan_dir (threaded SLAM tests)"
  cmake -S . -B "$tsan_dir" "${common[@]}" -DPORTA_SANITIZE=thread -DPORTA_BUILD_APPS=OFF
  cmake --build "$tsan_dir" -j "$jobs" --target porta_unit_tests porta_slam_tests
  ctest --test-dir "$tsan_dir" --output-on-failure --no-tests=error -j "$jobs" -L "^(unit|slam)$" \
    -R "^(Mapping|LoopClosing|Relocalisation|Tracking|TrackingMapLock|ThreadPool|FrontendInFlight|RenderSequence)\.|LoadFromSeveralThreads|^Map\.Yield|^OptimLocalBa\.SchurSolverGivesTheSameBits"
fi
echo "sanitize: done, no reports"
