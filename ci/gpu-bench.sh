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
have() { command -v "$1" >/dev/null 2>&1; }
if ! have nvcc && [ -x /usr/local/cuda/bin/nvcc ]; then export PATH="/usr/local/cuda/bin:$PATH"; fi

# ---- 1. The machine ------------------------------------------------------------------------------
{
  echo "date: $(date -u '+%Y-%m-%d %H:%M:%S UTC'); host $(hostname), $(uname -srm)"
  echo "commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)$(git diff --quiet 2>/dev/null || echo ' (with local changes)')"
  echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//'), $(nproc) hardware threads"
  have nvidia-smi && nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader | sed 's/^/gpu: /'
  have nvcc && echo "nvcc: $(nvcc --version | tail -1)"
} | tee "$out_dir/machine.txt"

# NVIDIA's OpenCL is found by the ICD loader only through an .icd file naming the driver's library;
# where none does, a private vendors folder in OUT_DIR serves this run (ci/gpu.sh registers it
# system-wide instead).
nvidia_cl="$(ldconfig -p 2>/dev/null | awk '$1 == "libnvidia-opencl.so.1" {print $NF; exit}')"
if [ -n "$nvidia_cl" ] && ! grep -qs libnvidia-opencl "${OCL_ICD_VENDORS:-/etc/OpenCL/vendors}"/*.icd; then
  mkdir -p "$out_dir/icd-vendors"
  cp /etc/OpenCL/vendors/*.icd "$out_dir/icd-vendors/" 2>/dev/null || true
  echo "libnvidia-opencl.so.1" >"$out_dir/icd-vendors/nvidia.icd"
  export OCL_ICD_VENDORS="$out_dir/icd-vendors"
  echo "opencl: NVIDIA's ICD registered for this run (OCL_ICD_VENDORS=$OCL_ICD_VENDORS)" | tee -a "$out_dir/machine.txt"
fi

# ---- 2. Build the program ------------------------------------------------------------------------
generator=(-G Ninja)
have ninja || generator=(-G "Unix Makefiles")
cmake_args=(-S . -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DPORTA_BUILD_APPS=ON
            -DPORTA_BUILD_TESTS=OFF -DPORTA_WERROR=OFF)
have nvcc && cmake_args+=(-DPORTA_WITH_CUDA=ON "-DCMAKE_CUDA_COMPILER=$(command -v nvcc)")
# shellcheck disable=SC2206  # extra arguments are split on spaces on purpose
extra=(${PORTA_GPU_CMAKE_ARGS:-})
build_log="$out_dir/build.log"
: >"$build_log"
left_out=()  # backends whose build failed
for attempt in 1 2 3 4; do
  off=()
  for b in "${left_out[@]}"; do off+=("-DPORTA_WITH_${b}=OFF"); done
  say "building portaslam in $build_dir (attempt $attempt${left_out[*]:+, without ${left_out[*]}}); log: $build_log"
  if cmake "${cmake_args[@]}" "${extra[@]}" "${off[@]}" >>"$build_log" 2>&1 &&
     cmake --build "$build_dir" --target portaslam -j "${PORTA_JOBS:-$(nproc)}" >>"$build_log" 2>&1; then
    built=1
    break
  fi
  built=0
  failing=""
  for b in CUDA VULKAN OPENCL; do
    lower="$(echo "$b" | tr '[:upper:]' '[:lower:]')"
    [[ " ${left_out[*]} " == *" $b "* ]] && continue
    if grep -qE "(FAILED|rror).*backends/$lower/" "$build_log"; then failing="$b"; break; fi
  done
  [ -z "$failing" ] && break
  left_out+=("$failing")
done
grep -E "PortaSLAM: (backend|OpenCV|portaslam)" "$build_log" | tail -8 | sed 's/^-- /  /'
binary="$build_dir/apps/portaslam"
if [ "$built" != 1 ] || [ ! -x "$binary" ]; then
  say "BUILD FAILED (last 30 lines of $build_log):"
  tail -30 "$build_log"
  grep -q "portaslam program is not built" "$build_log" && say "portaslam needs libpng (libpng-dev) or OpenCV"
  exit 1
fi
[ ${#left_out[@]} -gt 0 ] && echo "BUILD FAILED for: ${left_out[*]} (left out; see build.log)" | tee -a "$out_dir/machine.txt"

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
