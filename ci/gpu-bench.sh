#!/usr/bin/env bash
# The frontend throughput matrix on a GPU machine (docs/BENCHMARKS.md, "GPU machine"): builds the
# portaslam program with every backend this machine supports, runs `portaslam bench` on every
# backend that finds a device, then OpenCV's ORB from Python (bench/orb_peer.py) on the same
# images with our keypoint counts, and prints the ratios. Such a machine has no OpenCV C++, so
# portaslam is built with libpng and without its C++ peer; Python's cv2 is the peer.
#
#   usage: ci/gpu-bench.sh [OUT_DIR]        (default OUT_DIR: ./gpu-bench-results)
#   without network (packages carried by ci/fetch-gpu-deps.sh):
#          ci/gpu-carried.sh DEPS_DIR OUT_DIR ci/gpu-bench.sh
#
# Results in OUT_DIR: report.md (machine, our table, the peer's table and the ratios), ours.json and
# ours.txt (portaslam bench --json and its table), ours.log (its progress), peer.json and peer.txt
# (bench/orb_peer.py), backends.txt, machine.txt, build.log.
# Exit status: 0 when the build, every bench row and the peer succeeded; 1 otherwise.
#
# Needs: cmake >= 3.22, a C++20 compiler, Eigen 3, libpng (or OpenCV) for the program; the CUDA
# toolkit, the OpenCL ICD loader and headers, the Vulkan loader and glslang for those backends (as
# ci/gpu.sh says); Python 3 with numpy and cv2 (opencv-python-headless) for the peer.
# Environment: PORTA_BENCH_ARGS (more arguments of portaslam bench, e.g. "--frames 50" or
# "--resolutions 1242x375 --levels 8"; the peer follows the cells and frames of our JSON),
# PORTA_BENCH_BACKENDS (comma list; default: every backend available here, cpu included),
# PORTA_GPU_CMAKE_ARGS (extra CMake arguments), PORTA_DATA_DIR (the shared data folder),
# PORTA_JOBS (build parallelism, default all cores), PORTA_BENCH_BUILD_DIR (default
# build-gpu-bench), PORTA_PYTHON (default python3).
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.." || exit 1

mkdir -p "${1:-gpu-bench-results}" && out_dir="$(cd "${1:-gpu-bench-results}" && pwd)" || exit 1
build_dir="${PORTA_BENCH_BUILD_DIR:-build-gpu-bench}"
python="${PORTA_PYTHON:-python3}"
say() { echo "gpu-bench.sh: $*"; }
# shellcheck source=ci/gpu-common.sh
source ci/gpu-common.sh

# ---- 1. The machine, 2. the program (ci/gpu-common.sh) -------------------------------------------
gpu_machine_info
gpu_register_opencl
gpu_build "$build_dir" portaslam || exit 1

# ---- 3. Our matrix -------------------------------------------------------------------------------
"$binary" backends | tee "$out_dir/backends.txt"
backends="${PORTA_BENCH_BACKENDS:-$(awk 'NR > 1 && $2 == "yes" && $3 == "yes" {printf "%s%s", sep, $1; sep = ","}' "$out_dir/backends.txt")}"
# shellcheck disable=SC2206
bench_args=(${PORTA_BENCH_ARGS:-})
say "portaslam bench --backend $backends ${bench_args[*]} (progress: $out_dir/ours.log)"
"$binary" bench --backend "$backends" --json "$out_dir/ours.json" "${bench_args[@]}" \
  >"$out_dir/ours.txt" 2> >(tee "$out_dir/ours.log" >&2)
bench_status=$?
cat "$out_dir/ours.txt"

# ---- 4. The peer ---------------------------------------------------------------------------------
peer_status=1
if [ ! -s "$out_dir/ours.json" ]; then
  say "no ours.json: the peer is not run"
elif ! "$python" -c 'import cv2, numpy' 2>/dev/null; then
  say "no cv2 for $python: the peer is not run (pip install opencv-python-headless, then:"
  say "  $python bench/orb_peer.py --ours $out_dir/ours.json --json $out_dir/peer.json)"
else
  say "$python bench/orb_peer.py --ours ours.json --json peer.json"
  "$python" bench/orb_peer.py --ours "$out_dir/ours.json" --json "$out_dir/peer.json" >"$out_dir/peer.txt"
  peer_status=$?
  cat "$out_dir/peer.txt"
fi

# ---- 5. Report -----------------------------------------------------------------------------------
{
  echo "# PortaSLAM frontend throughput on $(hostname)"
  echo
  echo '```'
  cat "$out_dir/machine.txt"
  echo '```'
  echo
  echo "## portaslam bench --backend $backends ${bench_args[*]} (exit status $bench_status)"
  echo
  echo '```'
  cat "$out_dir/ours.txt"
  echo '```'
  echo
  echo "## bench/orb_peer.py --ours ours.json (exit status $peer_status)"
  echo
  echo '```'
  cat "$out_dir/peer.txt" 2>/dev/null || echo "(not run: see the log above)"
  echo '```'
} >"$out_dir/report.md"
say "results in $out_dir (report.md, ours.json, peer.json)"
[ "$bench_status" = 0 ] && [ "$peer_status" = 0 ] && [ ${#left_out[@]} -eq 0 ]
