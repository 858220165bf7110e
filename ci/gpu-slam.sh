#!/usr/bin/env bash
# The whole SLAM on a GPU machine (docs/BENCHMARKS.md, "SLAM on the GPU machine"): builds the
# portaslam program with the SLAM back end (Ceres) and every backend this machine supports, renders
# the first PORTA_SLAM_FRAMES (default 1000) frames of KITTI 00's path at 1242x375 (exact ground
# truth), and runs `portaslam run` on them:
#   1. deterministic mode on every backend (the runs side by side: their results do not depend on
#      timing), each backend's trajectory and keyframe files compared byte for byte with cpu's;
#      then the same on the built-in street-loop (612 frames), where a loop is closed, corrected
#      and globally adjusted (PORTA_SLAM_LOOP=0 skips it);
#   2. as fast as possible (realtime mode) on every backend, one after the other, PORTA_SLAM_REPEATS
#      (default 3) times each;
#   3. at camera rate (--rate 1) on each GPU backend over the first PORTA_SLAM_RATE_FRAMES (300).
# During every timed run nvidia-smi samples the GPU's utilisation and memory every 100 ms. Writes
# report.md (the tables; bench/slam_report.py) and keeps every run's summary JSON and log.
#
#   usage: ci/gpu-slam.sh [OUT_DIR]          (default OUT_DIR: ./gpu-slam-results)
#   without network (packages carried by ci/fetch-gpu-deps.sh):
#          ci/gpu-carried.sh DEPS_DIR OUT_DIR ci/gpu-slam.sh
#
# Needs what ci/gpu-bench.sh needs plus Ceres (libceres-dev, carried by ci/fetch-gpu-deps.sh) and
# KITTI 00's ground truth in PORTA_DATA_DIR/gt-trajectories (../shared/data; carried too); no
# OpenCV (the dataset reader reads PNG through libpng). Python 3 (standard library) for the report.
# Environment: PORTA_SLAM_FRAMES, PORTA_SLAM_REPEATS, PORTA_SLAM_RATE_FRAMES (0: no camera-rate
# runs), PORTA_SLAM_DETERMINISTIC (0: no deterministic runs, a quick timing check), PORTA_SLAM_BA_BENCH
# (0: no local BA, PNG reading or descriptor matching benchmark), PORTA_SLAM_RUN_ARGS (more
# `portaslam run` options for every run, e.g. "--mapping-threads 1" for a same-machine
# comparison), PORTA_SLAM_LOOP
# (0: no street-loop determinism check), PORTA_SLAM_BACKENDS
# (comma list; default every backend with a device), PORTA_GPU_CMAKE_ARGS, PORTA_DATA_DIR,
# PORTA_JOBS, PORTA_SLAM_BUILD_DIR (default build-gpu-slam), PORTA_SLAM_WORK (default OUT_DIR/work:
# the rendered sequence and the runs' trajectories).
# Exit status: 0 when everything built and ran and every backend's deterministic files equal cpu's.
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.." || exit 1

mkdir -p "${1:-gpu-slam-results}" && out_dir="$(cd "${1:-gpu-slam-results}" && pwd)" || exit 1
build_dir="${PORTA_SLAM_BUILD_DIR:-build-gpu-slam}"
work="${PORTA_SLAM_WORK:-$out_dir/work}"
data="${PORTA_DATA_DIR:-../shared/data}"
frames="${PORTA_SLAM_FRAMES:-1000}"
repeats="${PORTA_SLAM_REPEATS:-3}"
rate_frames="${PORTA_SLAM_RATE_FRAMES:-300}"
say() { echo "gpu-slam.sh: $*"; }
for setting in "PORTA_SLAM_FRAMES=$frames" "PORTA_SLAM_REPEATS=$repeats" "PORTA_SLAM_RATE_FRAMES=$rate_frames" \
               "PORTA_SLAM_DETERMINISTIC=${PORTA_SLAM_DETERMINISTIC:-1}" "PORTA_SLAM_LOOP=${PORTA_SLAM_LOOP:-1}"; do
  if ! [[ "${setting#*=}" =~ ^[0-9]+$ ]] || [ "${#setting}" -gt 40 ]; then
    say "${setting%%=*} must be a whole number, got '${setting#*=}'"
    exit 2
  fi
done
if [ "$frames" -lt 1 ] || [ "$repeats" -lt 1 ]; then
  say "PORTA_SLAM_FRAMES and PORTA_SLAM_REPEATS must be at least 1"
  exit 2
fi
# shellcheck source=ci/gpu-common.sh
source ci/gpu-common.sh
status=0

# ---- 1. The machine and the program --------------------------------------------------------------
gpu_machine_info
gpu_register_opencl
gpu_build "$build_dir" portaslam || exit 1
[ ${#left_out[@]} -gt 0 ] && status=1
if ! "$binary" run --help >/dev/null 2>&1; then
  say "this portaslam has no 'run' command: the SLAM back end was not built (Ceres missing?); see build.log"
  grep -E "PortaSLAM: (Ceres|OpenCV)" "$out_dir/build.log"
  exit 1
fi
"$binary" backends | tee "$out_dir/backends.txt"
with_device='NR > 1 && $2 == "yes" && $3 == "yes" {printf "%s%s", sep, $1; sep = ","}'
backends="${PORTA_SLAM_BACKENDS:-$(awk "$with_device" "$out_dir/backends.txt")}"
IFS=, read -r -a backend_list <<<"$backends"
say "backends: ${backend_list[*]}"

# ---- 2. The sequence -----------------------------------------------------------------------------
poses="$data/gt-trajectories/kitti00_poses.txt"
times="$data/gt-trajectories/kitti00_times.txt"
if [ ! -f "$poses" ] || [ ! -f "$times" ]; then
  say "no KITTI 00 ground truth in $data/gt-trajectories (set PORTA_DATA_DIR, or carry it with ci/fetch-gpu-deps.sh)"
  exit 1
fi
mkdir -p "$work"
seq="$work/k00"
if [ ! -f "$seq/poses.txt" ] || [ "$(wc -l <"$seq/poses.txt")" != "$frames" ]; then
  rm -rf "$seq"
  say "rendering $frames frames of KITTI 00's path into $seq"
  start_ns=$(date +%s%N)
  "$binary" render --trajectory "$poses" --times "$times" --count "$frames" --out "$seq" --quiet \
    >"$out_dir/render.log" 2>&1 || { tail -20 "$out_dir/render.log"; say "render FAILED"; exit 1; }
  echo "rendered $frames frames in $(( ($(date +%s%N) - start_ns) / 1000000 )) ms" | tee -a "$out_dir/render.log"
fi
md5="$data/peer-results/orbslam2-kitti00-render-1000/rendered_input.md5"
if [ "$frames" = 1000 ] && [ -f "$md5" ]; then
  if (cd "$seq" && md5sum --quiet -c "$md5") >"$out_dir/render_md5.txt" 2>&1; then
    echo "rendered images: the same bytes as the ORB-SLAM2 reference's input ($md5)" | tee -a "$out_dir/render_md5.txt"
  else
    echo "rendered images DIFFER from the ORB-SLAM2 reference's input ($md5)" | tee -a "$out_dir/render_md5.txt"
  fi
fi

# ---- 3. Runs --------------------------------------------------------------------------------------
# run_slam NAME ARGS...: one `portaslam run` on the sequence; summary in OUT_DIR/NAME.json, log in
# OUT_DIR/NAME.log, frames.csv and mapping.csv in OUT_DIR/NAME.*.csv, the KITTI-format trajectory in
# OUT_DIR/NAME.trajectory_kitti.txt, outputs in WORK/NAME, GPU
# samples in OUT_DIR/NAME.gpu.csv (timed runs only).
sampler=""
start_sampler() {
  sampler=""
  have nvidia-smi || return 0
  nvidia-smi --query-gpu=timestamp,utilization.gpu,memory.used --format=csv,noheader,nounits -lms 100 \
    >"$out_dir/$1.gpu.csv" 2>/dev/null &
  sampler=$!
  sleep 0.3
}
stop_sampler() { [ -n "$sampler" ] && kill "$sampler" 2>/dev/null && wait "$sampler" 2>/dev/null; sampler=""; }
run_slam() {
  local name="$1"
  shift
  # shellcheck disable=SC2086  # PORTA_SLAM_RUN_ARGS is split on spaces on purpose
  "$binary" run --dataset kitti "$seq" --out "$work/$name" --json "$out_dir/$name.json" --quiet \
    ${PORTA_SLAM_RUN_ARGS:-} "$@" >"$out_dir/$name.log" 2>&1
  local rc=$?
  cp "$work/$name/frames.csv" "$out_dir/$name.frames.csv" 2>/dev/null  # per frame: inliers, stage times
  cp "$work/$name/mapping.csv" "$out_dir/$name.mapping.csv" 2>/dev/null  # per keyframe: mapping's steps
  cp "$work/$name/trajectory_kitti.txt" "$out_dir/$name.trajectory_kitti.txt" 2>/dev/null  # for the RPE
  if [ $rc != 0 ]; then
    say "$name FAILED (exit $rc):"
    tail -5 "$out_dir/$name.log"
    status=1
  fi
  return $rc
}

deterministic="${PORTA_SLAM_DETERMINISTIC:-1}"
[ "$deterministic" = 0 ] && say "no deterministic runs (PORTA_SLAM_DETERMINISTIC=0)"
[ "$deterministic" = 0 ] || say "deterministic runs on ${backend_list[*]} (side by side)"
pids=()
for b in "${backend_list[@]}"; do
  [ "$deterministic" = 0 ] && break
  threads=()
  [ "$b" = cpu ] && threads=(--threads 4)
  run_slam "det-$b" --backend "$b" --mode deterministic "${threads[@]}" &
  pids+=($!)
done
for p in "${pids[@]}"; do wait "$p" || status=1; done
# compare_with_cpu PREFIX REPORT: every backend's PREFIX-<backend> files against cpu's, byte for byte.
compare_with_cpu() {
  : >"$2"
  for b in "${backend_list[@]}"; do
    [ "$b" = cpu ] && continue
    for f in trajectory_kitti.txt trajectory_tum.txt keyframes_tum.txt; do
      if cmp -s "$work/$1-cpu/$f" "$work/$1-$b/$f"; then
        echo "$b $f: identical to cpu's" >>"$2"
      else
        echo "$b $f: DIFFERS from cpu's" >>"$2"
        status=1
      fi
    done
  done
  cat "$2"
}
[ "$deterministic" = 0 ] || compare_with_cpu det "$out_dir/determinism.txt"

# The same with a loop closed, corrected and globally adjusted: the built-in street loop (612 frames).
if [ "$deterministic" != 0 ] && [ "${PORTA_SLAM_LOOP:-1}" != 0 ]; then
  say "deterministic runs with a loop closure (street-loop) on ${backend_list[*]}"
  "$binary" render --path street-loop --out "$work/street" --quiet >"$out_dir/render-street.log" 2>&1 ||
    { say "street-loop render FAILED"; status=1; }
  pids=()
  for b in "${backend_list[@]}"; do
    threads=()
    [ "$b" = cpu ] && threads=(--threads 4)
    "$binary" run --dataset kitti "$work/street" --out "$work/loop-$b" --json "$out_dir/loop-$b.json" --quiet \
      --backend "$b" --mode deterministic "${threads[@]}" >"$out_dir/loop-$b.log" 2>&1 &
    pids+=($!)
  done
  for p in "${pids[@]}"; do wait "$p" || status=1; done
  grep -h -E "^frames|closed,|global BA|^ATE" "$out_dir/loop-cpu.log" | tee "$out_dir/loop-determinism.txt"
  compare_with_cpu loop "$out_dir/loop-determinism.cmp"
  cat "$out_dir/loop-determinism.cmp" >>"$out_dir/loop-determinism.txt"
fi

for r in $(seq 1 "$repeats"); do
  for b in "${backend_list[@]}"; do
    say "as fast as possible: $b, run $r of $repeats"
    start_sampler "fast-$b-$r"
    run_slam "fast-$b-$r" --backend "$b"
    stop_sampler
  done
done
for b in "${backend_list[@]}"; do
  [ "$b" = cpu ] || [ "$rate_frames" = 0 ] && continue
  say "camera rate (--rate 1): $b, $rate_frames frames"
  start_sampler "rate1-$b"
  run_slam "rate1-$b" --backend "$b" --rate 1 --frames "$rate_frames"
  stop_sampler
done

# ---- 3b. Local bundle adjustment on the host's threads (porta_ba_bench; needs Google Benchmark) --
if [ "${PORTA_SLAM_BA_BENCH:-1}" != 0 ]; then
  say "local BA benchmark: one thread against the split loops on 1, 2, 4 and 8; pose-only optimisation"
  if cmake --build "$build_dir" --target porta_ba_bench -j "${PORTA_JOBS:-$(nproc)}" >>"$out_dir/build.log" 2>&1; then
    "$build_dir/bench/porta_ba_bench" --benchmark_filter='Schur($|Threads)|PoseOptimization' --benchmark_repetitions=5 \
      --benchmark_report_aggregates_only=true >"$out_dir/ba-bench.txt" 2>&1 || status=1
  else
    echo "porta_ba_bench not built (Google Benchmark missing? see build.log)" >"$out_dir/ba-bench.txt"
  fi
fi

# ---- 3c. Reading the images: imageio's reader against libpng alone (porta_png_bench) -------------
if [ "${PORTA_SLAM_BA_BENCH:-1}" != 0 ]; then
  say "PNG reading benchmark on the rendered left images"
  if cmake --build "$build_dir" --target porta_png_bench -j "${PORTA_JOBS:-$(nproc)}" >>"$out_dir/build.log" 2>&1; then
    PORTA_PNG_BENCH_DIR="$seq/image_0" "$build_dir/bench/porta_png_bench" --benchmark_repetitions=5 \
      --benchmark_report_aggregates_only=true >"$out_dir/png-bench.txt" 2>&1 || status=1
  else
    echo "porta_png_bench not built (Google Benchmark missing? see build.log)" >"$out_dir/png-bench.txt"
  fi
fi

# ---- 3d. Descriptor matching's scan: whether this host's CPU counts bits in vectors (porta_match_bench)
if [ "${PORTA_SLAM_BA_BENCH:-1}" != 0 ]; then
  say "descriptor matching benchmark (loop verification, relocalisation)"
  if cmake --build "$build_dir" --target porta_match_bench -j "${PORTA_JOBS:-$(nproc)}" \
       >>"$out_dir/build.log" 2>&1; then
    # A CPU without AVX-512 VPOPCNTDQ reports the vector row as an error; that is an answer, not a failure.
    "$build_dir/bench/porta_match_bench" --benchmark_repetitions=5 --benchmark_report_aggregates_only=true \
      >"$out_dir/match-bench.txt" 2>&1 || true
  else
    echo "porta_match_bench not built (Google Benchmark missing? see build.log)" >"$out_dir/match-bench.txt"
  fi
fi

# ---- 4. Report -------------------------------------------------------------------------------------
python3 bench/slam_report.py --results "$out_dir" --work "$work" --backends "$backends" >"$out_dir/report.md" ||
  { say "report FAILED"; status=1; }
if [ -f "$out_dir/loop-determinism.txt" ]; then
  printf '\n### Deterministic mode with a loop closure (street-loop, 612 frames)\n\n```\n%s\n```\n' \
    "$(cat "$out_dir/loop-determinism.txt")" >>"$out_dir/report.md"
fi
if [ -f "$out_dir/ba-bench.txt" ]; then
  printf '\n### Local bundle adjustment on this host (porta_ba_bench, medians of 5)\n\n```\n%s\n```\n' \
    "$(grep -E '_median|not built' "$out_dir/ba-bench.txt" | sed 's/ \{2,\}/  /g')" >>"$out_dir/report.md"
fi
if [ -f "$out_dir/png-bench.txt" ]; then
  printf '\n### Reading the rendered PNG images on this host (porta_png_bench, medians of 5)\n\n```\n%s\n```\n' \
    "$(grep -E '_median|not built|ERROR' "$out_dir/png-bench.txt" | sed 's/ \{2,\}/  /g')" >>"$out_dir/report.md"
fi
if [ -f "$out_dir/match-bench.txt" ]; then
  printf '\n### Descriptor matching on this host (porta_match_bench, medians of 5)\n\n```\n%s\n```\n' \
    "$(grep -E '_median|not built|ERROR|VPOPCNTDQ' "$out_dir/match-bench.txt" | sed 's/ \{2,\}/  /g')" \
    >>"$out_dir/report.md"
fi
cat "$out_dir/report.md"
say "results in $out_dir (report.md, *.json, *.log, *.gpu.csv)"
exit $status
