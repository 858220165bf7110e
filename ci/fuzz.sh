#!/usr/bin/env bash
# Fuzzes every parser and reader with libFuzzer (docs/RELIABILITY.md): builds the fuzz targets of
# tests/fuzz with clang, ASan + UBSan and coverage (build-fuzz), makes the seed corpora, then runs
# each target for PORTA_FUZZ_RUNS executions (default 20000 with the fixed seed PORTA_FUZZ_SEED=1:
# CI's short run, the same inputs on every run, about a minute for all six) or, when
# PORTA_FUZZ_SECONDS is set, for that many seconds. Prints one line per target: executions, and exits non-zero on
# the first crash, hang, leak or sanitizer report (libFuzzer saves the input as crash-*/timeout-*
# in build-fuzz/findings). Called by ci/test.sh; needs clang and libclang-rt (ci/setup.sh).
#   PORTA_FUZZ_SECONDS=600 PORTA_FUZZ_SEED=7 bash ci/fuzz.sh   # a long run, a random seed
#   PORTA_FUZZ_RUNS=1000000 bash ci/fuzz.sh                    # a million executions per target
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

build_dir="${PORTA_FUZZ_BUILD_DIR:-build-fuzz}"
jobs="${PORTA_JOBS:-2}"
seconds="${PORTA_FUZZ_SECONDS:-}"
runs="${PORTA_FUZZ_RUNS:-20000}"
seed="${PORTA_FUZZ_SEED:-1}"
targets=(png settings trajectory kitti euroc map_file)
declare -A seeds=([png]=png [settings]=settings [trajectory]=trajectory [kitti]=kitti [euroc]=euroc [map_file]=map)

CXX="${PORTA_FUZZ_CXX:-clang++}" cmake -S . -B "$build_dir" -G Ninja -DPORTA_WERROR=OFF -DPORTA_FUZZ=ON \
  -DPORTA_SANITIZE=address,undefined,fuzzer-no-link -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1" -DPORTA_BUILD_APPS=OFF \
  -DPORTA_WITH_VULKAN=OFF -DPORTA_WITH_OPENCL=OFF -DPORTA_WITH_CUDA=OFF > /dev/null
cmake --build "$build_dir" -j "$jobs" --target porta_fuzz_make_seeds "${targets[@]/#/porta_fuzz_}"

export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
"$build_dir/tests/fuzz/porta_fuzz_make_seeds" "$build_dir/seeds" settings
mkdir -p "$build_dir/findings"
limit=(-runs="$runs" -seed="$seed")
if [ -n "$seconds" ]; then limit=(-max_total_time="$seconds" -seed="$seed"); fi
for t in "${targets[@]}"; do
  corpus="$build_dir/corpus/$t"
  mkdir -p "$corpus"
  cp -n "$build_dir/seeds/${seeds[$t]}"/* "$corpus/"
  log="$build_dir/findings/$t.log"
  if ! (cd "$build_dir/findings" && "../tests/fuzz/porta_fuzz_$t" "${limit[@]}" -timeout=10 -rss_limit_mb=2048 \
          -print_final_stats=1 "../corpus/$t") > "$log" 2>&1; then
    tail -40 "$log"
    echo "fuzz: $t FAILED (input and log in $build_dir/findings)"
    exit 1
  fi
  executions=$(grep -oE "stat::number_of_executed_units: *[0-9]+" "$log" | grep -oE "[0-9]+$" || echo "?")
  echo "fuzz: $t: $executions executions, 0 crashes, 0 hangs, 0 sanitizer reports"
done
