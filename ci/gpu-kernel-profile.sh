#!/usr/bin/env bash
# Issue 16's cells on a GPU machine, kernel by kernel (docs/BENCHMARKS.md, "Per-kernel profile"):
# builds portaslam with every backend the machine supports, times the four cells of the issue's
# table (1242x375 8 levels stereo and extract, 752x480 8 levels detect, 320x240 1 level detect) on
# every backend that finds a device, one frame at a time, then again with --profile-kernels on
# vulkan and opencl: the device time of each kernel per frame (timestamp queries, profiling events).
#
#   usage: ci/gpu-kernel-profile.sh [OUT_DIR]      (default OUT_DIR: ./gpu-kernel-profile)
#   without network: ci/gpu-carried.sh DEPS_DIR OUT_DIR ci/gpu-kernel-profile.sh
#
# Results in OUT_DIR: report.md (machine, the frame times, the per-kernel tables), frames-*.txt and
# .json (portaslam bench without profiling), kernels-*.txt and .json (with it), backends.txt,
# machine.txt, build.log, cl-enqueue.txt (porta_cl_enqueue_bench: the host's cost of OpenCL calls,
# when opencl is among the backends). Exit status: 0 when the build and every bench run succeeded.
# The frame times are taken one frame at a time and with 4 frames in flight, with the input copied
# by the host and in pinned input images (PORTA_PROFILE_BENCH_ARGS, default "--in-flight 1,4 --input
# copy,pinned"), and once more for vulkan and opencl with one queue (PORTA_VULKAN_QUEUES=1,
# PORTA_OPENCL_QUEUES=1: every call in order, results downloaded after the frame), the way they ran
# before they had queues (frames-*-one-queue.txt), and with the pyramid's levels in one dispatch
# (PORTA_VULKAN_FUSED_PYRAMID=on PORTA_OPENCL_FUSED_PYRAMID=on: frames-*-fused.txt, kernels-*-fused.txt),
# and with their detection in four kernels instead of two fused ones (PORTA_VULKAN_FUSED_DETECT=off
# PORTA_OPENCL_FUSED_DETECT=off: frames-*-unfused-detect.txt, kernels-*-unfused-detect.txt).
# Environment: PORTA_PROFILE_FRAMES (timed frames per cell, default 200; warm-up 20),
# PORTA_GPU_CMAKE_ARGS, PORTA_JOBS, PORTA_DATA_DIR as ci/gpu-common.sh reads them,
# PORTA_PROFILE_BUILD_DIR (default build-gpu-bench, shared with ci/gpu-bench.sh), PORTA_PROFILE_CELLS
# (names of the cells to run, e.g. "320x240-1 752x480-8"; default all), PORTA_PROFILE_BACKENDS
# (default: every backend available), PORTA_PROFILE_VARIANTS (which of the runs beside the default
# to make: "one-queue fused-pyramid unfused-detect", the default, or a subset; "none" for none;
# also, on vulkan only, frame times with its copies on the transfer queue "transfer-queue"
# (PORTA_VULKAN_TRANSFER_QUEUE=on: frames-*-transfer-queue.txt), that and no held batches "unheld"
# (PORTA_VULKAN_HOLD_BATCHES=off), that and its streams on 4 device queues "device-queues"
# (PORTA_VULKAN_DEVICE_QUEUES=4), the transfer queue with a frame held only while 2 batches are
# still to run "hold-2" (PORTA_VULKAN_HOLD_BATCHES=2); on vulkan and opencl, PFA's first step in
# PFA's own launches rather than the cull's "pfa-apart" (PORTA_VULKAN_PFA_IN_CULL=off
# PORTA_OPENCL_PFA_IN_CULL=off: frames-*-pfa-apart.txt, kernels-*-pfa-apart.txt); on vulkan, the
# cull's launch not finishing detection "cull-unfinished" (PORTA_VULKAN_CULL_FINISHES=off:
# frames-*-cull-unfinished.txt, kernels-*-cull-unfinished.txt); and "repeat": the default frame
# times once more, last, to see the run's drift). The backends' own variables (PORTA_VULKAN_DEVICE_QUEUES, ...)
# pass through. PORTA_PROFILE_SETTINGS adds runs of any settings, on vulkan and opencl, frame times
# and per-kernel device time: "NAME NAME=VALUE ...; NAME NAME=VALUE ..." (e.g. "px4
# PORTA_VULKAN_CULL_PIXELS=4"), in frames-*-NAME.txt and kernels-*-NAME.txt, after the variants.
# PORTA_PROFILE_REPEATS=N (1 to 20, default 1): the default frame times N - 1 times more, at the end
# of each cell (frames-*-repeat-K.json); report.md ends with issue 16's table, each figure the
# median over the default run, these and "repeat" (bench/backend_table.py; needs python3).
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.." || exit 1

mkdir -p "${1:-gpu-kernel-profile}" && out_dir="$(cd "${1:-gpu-kernel-profile}" && pwd)" || exit 1
build_dir="${PORTA_PROFILE_BUILD_DIR:-build-gpu-bench}"
frames="${PORTA_PROFILE_FRAMES:-200}"
read -r -a bench_args <<<"${PORTA_PROFILE_BENCH_ARGS:---in-flight 1,4 --input copy,pinned}"
say() { echo "gpu-kernel-profile.sh: $*"; }
# shellcheck source=ci/gpu-common.sh
source ci/gpu-common.sh

# The settings, checked before anything is built.
case "$frames" in '' | *[!0-9]* | 0) say "PORTA_PROFILE_FRAMES must be a whole number of frames, got '$frames'"; exit 1 ;; esac
repeats="${PORTA_PROFILE_REPEATS:-1}"
case "$repeats" in [1-9] | 1[0-9] | 20) ;; *) say "PORTA_PROFILE_REPEATS must be a number of runs from 1 to 20, got '$repeats'"; exit 1 ;; esac
variants="${PORTA_PROFILE_VARIANTS:-one-queue fused-pyramid unfused-detect}"
variant() { case " $variants " in *" $1 "*) return 0 ;; esac; return 1; }
for v in $variants; do
  case "$v" in one-queue | fused-pyramid | unfused-detect | transfer-queue | unheld | device-queues | hold-2 | pfa-apart | cull-unfinished | repeat | none) ;;
  *) say "PORTA_PROFILE_VARIANTS names '$v'; known: one-queue fused-pyramid unfused-detect transfer-queue unheld device-queues hold-2 pfa-apart cull-unfinished repeat none"
     exit 1 ;;
  esac
done
# name: resolution levels modes
cells=("1242x375-8:1242x375 8 stereo,extract" "752x480-8:752x480 8 detect" "320x240-1:320x240 1 detect")
if [ -n "${PORTA_PROFILE_CELLS:-}" ]; then  # e.g. "320x240-1 752x480-8": only those
  kept=()
  for cell in "${cells[@]}"; do
    case " $PORTA_PROFILE_CELLS " in *" ${cell%%:*} "*) kept+=("$cell") ;; esac
  done
  [ "${#kept[@]}" -gt 0 ] || { say "PORTA_PROFILE_CELLS='$PORTA_PROFILE_CELLS' names no cell (1242x375-8, 752x480-8, 320x240-1)"; exit 1; }
  cells=("${kept[@]}")
fi

gpu_machine_info
gpu_register_opencl
gpu_build "$build_dir" portaslam || exit 1
"$binary" backends | tee "$out_dir/backends.txt"
available() { awk -v b="$1" 'NR > 1 && $1 == b && $2 == "yes" && $3 == "yes" {found = 1} END {exit !found}' "$out_dir/backends.txt"; }
all="" timed=""
for b in ${PORTA_PROFILE_BACKENDS:-cpu cuda vulkan opencl}; do
  available "$b" || continue
  all="${all:+$all,}$b"
  case "$b" in vulkan | opencl) timed="${timed:+$timed,}$b" ;; esac
done
[ -n "$all" ] || { say "no backend available"; exit 1; }

status=0
# A variant of cell $name: frame times and per-kernel device time on BACKENDS with the settings
# (NAME=VALUE words), in frames-$name-SUFFIX.txt and kernels-$name-SUFFIX.txt (and .json).
variant_run() {
  local suffix="$1" backends="$2"
  shift 2
  say "cell $name: $backends with $*"
  env "$@" "$binary" bench --backend "$backends" "${common[@]}" "${bench_args[@]}" \
    --json "$out_dir/frames-$name-$suffix.json" >"$out_dir/frames-$name-$suffix.txt" \
    2>>"$out_dir/bench.log" || status=1
  env "$@" "$binary" bench --backend "$backends" "${common[@]}" --profile-kernels \
    --json "$out_dir/kernels-$name-$suffix.json" >"$out_dir/kernels-$name-$suffix.txt" \
    2>>"$out_dir/bench.log" || status=1
}
for cell in "${cells[@]}"; do
  name="${cell%%:*}"
  read -r size levels modes <<<"${cell#*:}"
  common=(--resolutions "$size" --levels "$levels" --modes "$modes" --frames "$frames" --warmup 20 --no-peer)
  say "cell $name: frame times on $all"
  "$binary" bench --backend "$all" "${common[@]}" "${bench_args[@]}" --json "$out_dir/frames-$name.json" \
    >"$out_dir/frames-$name.txt" 2>>"$out_dir/bench.log" || status=1
  if [ -n "$timed" ] && variant one-queue; then
    say "cell $name: $timed with one queue"
    PORTA_VULKAN_QUEUES=1 PORTA_OPENCL_QUEUES=1 "$binary" bench --backend "$timed" "${common[@]}" \
      --json "$out_dir/frames-$name-one-queue.json" >"$out_dir/frames-$name-one-queue.txt" \
      2>>"$out_dir/bench.log" || status=1
  fi
  if [ -n "$timed" ]; then
    say "cell $name: per-kernel device time on $timed"
    "$binary" bench --backend "$timed" "${common[@]}" --profile-kernels --json "$out_dir/kernels-$name.json" \
      >"$out_dir/kernels-$name.txt" 2>>"$out_dir/bench.log" || status=1
  fi
  if [ -n "$timed" ] && variant fused-pyramid; then
    variant_run fused "$timed" PORTA_VULKAN_FUSED_PYRAMID=on PORTA_OPENCL_FUSED_PYRAMID=on
  fi
  if [ -n "$timed" ] && variant unfused-detect; then
    variant_run unfused-detect "$timed" PORTA_VULKAN_FUSED_DETECT=off PORTA_OPENCL_FUSED_DETECT=off
  fi
  if [ -n "$timed" ] && variant pfa-apart; then
    variant_run pfa-apart "$timed" PORTA_VULKAN_PFA_IN_CULL=off PORTA_OPENCL_PFA_IN_CULL=off
  fi
  if [[ ",$all," == *",vulkan,"* ]] && variant cull-unfinished; then
    variant_run cull-unfinished vulkan PORTA_VULKAN_CULL_FINISHES=off
  fi
  # vulkan's queue settings, frame times only: "variant environment...".
  for setting in "transfer-queue PORTA_VULKAN_TRANSFER_QUEUE=on" \
    "unheld PORTA_VULKAN_TRANSFER_QUEUE=on PORTA_VULKAN_HOLD_BATCHES=off" \
    "device-queues PORTA_VULKAN_TRANSFER_QUEUE=on PORTA_VULKAN_HOLD_BATCHES=off PORTA_VULKAN_DEVICE_QUEUES=4" \
    "hold-2 PORTA_VULKAN_TRANSFER_QUEUE=on PORTA_VULKAN_HOLD_BATCHES=2"; do
    read -r v settings <<<"$setting"
    { [[ ",$all," == *",vulkan,"* ]] && variant "$v"; } || continue
    say "cell $name: vulkan with $settings"
    # shellcheck disable=SC2086  # the settings are words of NAME=VALUE
    env $settings "$binary" bench --backend vulkan "${common[@]}" "${bench_args[@]}" \
      --json "$out_dir/frames-$name-$v.json" >"$out_dir/frames-$name-$v.txt" 2>>"$out_dir/bench.log" || status=1
  done
  if [ -n "$timed" ] && [ -n "${PORTA_PROFILE_SETTINGS:-}" ]; then
    IFS=';' read -r -a extra <<<"$PORTA_PROFILE_SETTINGS"
    for setting in "${extra[@]}"; do
      read -r v settings <<<"$setting"
      [ -n "$v" ] || continue
      # shellcheck disable=SC2086  # the settings are words of NAME=VALUE
      variant_run "$v" "$timed" $settings
    done
  fi
  if variant repeat; then
    say "cell $name: frame times on $all again"
    "$binary" bench --backend "$all" "${common[@]}" "${bench_args[@]}" --json "$out_dir/frames-$name-repeat.json" \
      >"$out_dir/frames-$name-repeat.txt" 2>>"$out_dir/bench.log" || status=1
  fi
  for ((k = 2; k <= repeats; k++)); do
    say "cell $name: frame times on $all, run $k of $repeats"
    "$binary" bench --backend "$all" "${common[@]}" "${bench_args[@]}" --json "$out_dir/frames-$name-repeat-$k.json" \
      >"$out_dir/frames-$name-repeat-$k.txt" 2>>"$out_dir/bench.log" || status=1
  done
done

# The host's cost of OpenCL calls on this device (porta_cl_enqueue_bench): what bounds opencl with
# frames in flight.
if available opencl && [[ ",$all," == *",opencl,"* ]]; then
  say "OpenCL host costs (porta_cl_enqueue_bench)"
  if cmake --build "$build_dir" --target porta_cl_enqueue_bench -j "${PORTA_JOBS:-$(nproc)}" >>"$out_dir/build.log" 2>&1; then
    "$build_dir/bench/porta_cl_enqueue_bench" --benchmark_repetitions=3 --benchmark_report_aggregates_only=true \
      >"$out_dir/cl-enqueue.txt" 2>&1 || status=1
  else
    echo "porta_cl_enqueue_bench not built (Google Benchmark missing? see build.log)" >"$out_dir/cl-enqueue.txt"
  fi
fi

{
  echo "# Per-kernel profile on $(hostname)"
  echo
  echo '```'
  cat "$out_dir/machine.txt"
  echo '```'
  for cell in "${cells[@]}"; do
    name="${cell%%:*}"
    echo
    echo "## $name"
    echo
    echo '```'
    cat "$out_dir/frames-$name.txt" 2>/dev/null
    echo "one queue:"
    grep -E '^(vulkan|opencl) ' "$out_dir/frames-$name-one-queue.txt" 2>/dev/null
    sed -n '/^Per-kernel device time/,$p' "$out_dir/kernels-$name.txt" 2>/dev/null
    echo "the pyramid in one dispatch (PORTA_VULKAN_FUSED_PYRAMID=on PORTA_OPENCL_FUSED_PYRAMID=on):"
    grep -E '^(vulkan|opencl)' "$out_dir/frames-$name-fused.txt" 2>/dev/null
    sed -n '/^Per-kernel device time/,$p' "$out_dir/kernels-$name-fused.txt" 2>/dev/null | grep -E "^(vulkan|opencl),|pyramid|^  all"
    echo "detection in four kernels (PORTA_VULKAN_FUSED_DETECT=off PORTA_OPENCL_FUSED_DETECT=off):"
    grep -E '^(vulkan|opencl)' "$out_dir/frames-$name-unfused-detect.txt" 2>/dev/null
    sed -n '/^Per-kernel device time/,$p' "$out_dir/kernels-$name-unfused-detect.txt" 2>/dev/null
    for v in pfa-apart cull-unfinished transfer-queue unheld device-queues hold-2 repeat; do
      [ -f "$out_dir/frames-$name-$v.txt" ] || continue
      echo "$v:"
      grep -E '^(cpu|cuda|vulkan|opencl)' "$out_dir/frames-$name-$v.txt"
    done
    sed -n '/^Per-kernel device time/,$p' "$out_dir/kernels-$name-pfa-apart.txt" 2>/dev/null
    sed -n '/^Per-kernel device time/,$p' "$out_dir/kernels-$name-cull-unfinished.txt" 2>/dev/null
    if [ -n "${PORTA_PROFILE_SETTINGS:-}" ]; then
      IFS=';' read -r -a extra <<<"$PORTA_PROFILE_SETTINGS"
      for setting in "${extra[@]}"; do
        read -r v settings <<<"$setting"
        [ -f "$out_dir/frames-$name-$v.txt" ] || continue
        echo "$v ($settings):"
        grep -E '^(vulkan|opencl)' "$out_dir/frames-$name-$v.txt"
        sed -n '/^Per-kernel device time/,$p' "$out_dir/kernels-$name-$v.txt" 2>/dev/null
      done
    fi
    echo '```'
  done
  if [ -f "$out_dir/cl-enqueue.txt" ]; then
    printf '\n## OpenCL host costs (porta_cl_enqueue_bench, medians of 3)\n\n```\n'
    grep -E "porta_cl|_median|not built" "$out_dir/cl-enqueue.txt"
    echo '```'
  fi
} >"$out_dir/report.md"

# Issue 16's table: every cell's default runs, each figure the median over them.
runs=()
for cell in "${cells[@]}"; do
  name="${cell%%:*}"
  for f in "$out_dir/frames-$name.json" "$out_dir/frames-$name-repeat.json" "$out_dir/frames-$name-repeat-"*.json; do
    [ -f "$f" ] && runs+=("$f")
  done
done
if [ "${#runs[@]}" -gt 0 ] && command -v python3 >/dev/null; then
  {
    printf '\n%s\n\n' "## Issue 16's table (bench/backend_table.py over the default runs)"
    python3 bench/backend_table.py --reference cuda --within vulkan=1.5 --within opencl=2 --faster-than cpu \
      "${runs[@]}" 2>&1
  } >>"$out_dir/report.md" || status=1
fi
say "results in $out_dir (report.md); exit status $status"
exit "$status"
