#!/usr/bin/env bash
# Runs the cross-backend equivalence suite (docs/EQUIVALENCE.md) on a machine with an NVIDIA GPU:
# builds every backend this machine supports (CUDA with nvcc; OpenCL with the ICD loader, where
# NVIDIA's own OpenCL is one more device; Vulkan with its loader and glslang), runs every kernel and
# the whole frontend of each backend against the cpu reference, byte for byte, and prints a summary
# table (kernels x backends).
#
#   usage: ci/gpu.sh [OUT_DIR]        (default OUT_DIR: ./gpu-results)
#
# Results in OUT_DIR: report.md (machine, devices, summary table), summary.md (the table alone),
# equivalence.log (every case), equivalence.xml (JUnit), build.log, machine.txt; and the same
# again with the kernels vulkan and opencl run on CPU devices (*-cpu-paths.*; PORTA_GPU_CPU_PATHS=off
# leaves that run out).
# Exit status: 0 when every backend that was built and has a device passed every case; 1 otherwise
# (a failed case, a backend that did not build, or a built backend that found no device).
#
# What the machine needs (Ubuntu/Debian package names in brackets):
#   - cmake >= 3.22 [cmake], a C++20 compiler [g++ >= 11], ninja [ninja-build] (else make is used),
#     Eigen 3 [libeigen3-dev], GoogleTest [libgtest-dev]. OpenCV is NOT needed; libpng [libpng-dev]
#     lets the suite read the real images of ../shared/data (without it those inputs are skipped).
#   - CUDA backend: the CUDA toolkit (nvcc; /usr/local/cuda/bin is searched) and the NVIDIA driver.
#   - OpenCL backend: headers [opencl-headers] and the ICD loader libOpenCL.so [ocl-icd-opencl-dev],
#     plus an ICD file naming NVIDIA's OpenCL library: /etc/OpenCL/vendors/nvidia.icd containing
#     the line `libnvidia-opencl.so.1`. The NVIDIA driver ships the library (libnvidia-opencl.so.1)
#     but containers often lack the ICD file; this script writes it when the library exists (as
#     root, else with sudo, else in a private vendors folder through OCL_ICD_VENDORS).
#   - Vulkan backend (optional): [libvulkan-dev glslang-tools] and the NVIDIA Vulkan ICD.
# Environment: PORTA_GPU_CMAKE_ARGS (extra CMake arguments), PORTA_OPENCL_DEVICE (which OpenCL
# device the opencl backend uses: index or name substring; default the first GPU), PORTA_DATA_DIR
# (the shared data folder), PORTA_JOBS (build parallelism, default: all cores).
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.." || exit 1

out_dir="${1:-gpu-results}"
mkdir -p "$out_dir"
out_dir="$(cd "$out_dir" && pwd)"
build_dir="${PORTA_GPU_BUILD_DIR:-build-gpu}"
jobs="${PORTA_JOBS:-$(nproc 2>/dev/null || echo 4)}"
machine="$out_dir/machine.txt"
: >"$machine"

say() { echo "gpu.sh: $*"; }
case "${PORTA_GPU_CPU_PATHS:-on}" in
  on | off) ;;
  *) say "PORTA_GPU_CPU_PATHS must be on or off, got '${PORTA_GPU_CPU_PATHS}'"; exit 1 ;;
esac
record() { echo "$*" | tee -a "$machine"; }
have() { command -v "$1" >/dev/null 2>&1; }

# ---- 1. The machine ------------------------------------------------------------------------------
record "date: $(date -u '+%Y-%m-%d %H:%M:%S UTC')"
record "host: $(hostname) ($(uname -srm))"
record "commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)$(git diff --quiet 2>/dev/null || echo ' (with local changes)')"
if have nvidia-smi; then
  record "nvidia-smi -L:"
  nvidia-smi -L 2>&1 | sed 's/^/  /' | tee -a "$machine"
  record "driver: $(nvidia-smi --query-gpu=driver_version --format=csv,noheader 2>/dev/null | head -1)"
else
  record "nvidia-smi: not found (no NVIDIA driver visible: the CUDA and NVIDIA OpenCL runs will not find a device)"
fi

# ---- 2. What is there and what is missing --------------------------------------------------------
missing_required=()
if ! have nvcc && [ -x /usr/local/cuda/bin/nvcc ]; then export PATH="/usr/local/cuda/bin:$PATH"; fi
check_tool() {  # name, package, required?
  if have "$1"; then record "found: $1 ($(command -v "$1"))"
  elif [ "$3" = required ]; then record "MISSING: $1 (install $2)"; missing_required+=("$1")
  else record "missing (optional): $1 (install $2)"; fi
}
check_tool cmake cmake required
check_tool c++ g++ required
check_tool ninja ninja-build optional
check_tool nvcc "the CUDA toolkit" optional
check_tool clinfo clinfo optional
have nvcc && record "nvcc: $(nvcc --version | tail -1)"

find_lib() {  # prints the path of library $1 (a file name), or nothing
  local p
  p="$(ldconfig -p 2>/dev/null | awk -v n="$1" '$1 == n {print $NF; exit}')"
  if [ -n "$p" ]; then echo "$p"; return; fi
  for d in /usr/lib/x86_64-linux-gnu /usr/lib64 /usr/lib /usr/local/nvidia/lib64 /usr/local/nvidia/lib \
           /usr/local/cuda/lib64 /usr/local/cuda/targets/x86_64-linux/lib /usr/lib/aarch64-linux-gnu; do
    if [ -e "$d/$1" ]; then echo "$d/$1"; return; fi
  done
}

opencl_ok=1
if [ -e /usr/include/CL/cl.h ] || [ -e /usr/local/cuda/include/CL/cl.h ]; then
  record "found: OpenCL headers (CL/cl.h)"
else
  record "MISSING: OpenCL headers CL/cl.h (install opencl-headers): the opencl backend is not built"; opencl_ok=0
fi
loader="$(find_lib libOpenCL.so)"
[ -z "$loader" ] && loader="$(find_lib libOpenCL.so.1)"
if [ -n "$loader" ]; then
  record "found: OpenCL ICD loader ($loader)"
else
  record "MISSING: the OpenCL ICD loader libOpenCL.so (install ocl-icd-opencl-dev): the opencl backend is not built"
  opencl_ok=0
fi

# NVIDIA's OpenCL: the driver's library must be named by an ICD file for the loader to find it.
vendors_dir="${OCL_ICD_VENDORS:-/etc/OpenCL/vendors}"
nvidia_cl="$(find_lib libnvidia-opencl.so.1)"
if [ -z "$nvidia_cl" ]; then
  record "missing: libnvidia-opencl.so.1 (NVIDIA's OpenCL, part of the driver): the opencl backend will not see the GPU"
elif grep -qs "libnvidia-opencl" "$vendors_dir"/*.icd 2>/dev/null; then
  record "found: NVIDIA OpenCL ICD ($(grep -ls libnvidia-opencl "$vendors_dir"/*.icd | head -1) -> $nvidia_cl)"
else
  # The bare name works when the dynamic linker knows the library; else write its full path.
  icd_line="libnvidia-opencl.so.1"
  ldconfig -p 2>/dev/null | grep -q "libnvidia-opencl.so.1 " || icd_line="$nvidia_cl"
  if [ -w /etc/OpenCL/vendors ] || { [ ! -e /etc/OpenCL/vendors ] && [ "$(id -u)" = 0 ]; }; then
    mkdir -p /etc/OpenCL/vendors && echo "$icd_line" >/etc/OpenCL/vendors/nvidia.icd
    record "registered NVIDIA OpenCL: wrote /etc/OpenCL/vendors/nvidia.icd = $icd_line"
  elif have sudo && sudo -n true 2>/dev/null; then
    sudo mkdir -p /etc/OpenCL/vendors && echo "$icd_line" | sudo tee /etc/OpenCL/vendors/nvidia.icd >/dev/null
    record "registered NVIDIA OpenCL: wrote /etc/OpenCL/vendors/nvidia.icd = $icd_line (sudo)"
  else
    private="$out_dir/icd-vendors"
    mkdir -p "$private"
    cp /etc/OpenCL/vendors/*.icd "$private"/ 2>/dev/null || true
    echo "$icd_line" >"$private/nvidia.icd"
    export OCL_ICD_VENDORS="$private"
    record "registered NVIDIA OpenCL privately: OCL_ICD_VENDORS=$private (no root; to make it permanent:"
    record "  echo $icd_line | sudo tee /etc/OpenCL/vendors/nvidia.icd)"
  fi
fi

if [ ${#missing_required[@]} -gt 0 ]; then
  say "cannot build: missing ${missing_required[*]} (see above)"
  exit 1
fi

# ---- 3. Devices ----------------------------------------------------------------------------------
if have clinfo; then
  record "OpenCL devices (clinfo -l):"
  clinfo -l 2>&1 | sed 's/^/  /' | tee -a "$machine"
fi

# ---- 4. Build what this machine supports ---------------------------------------------------------
generator=(-G Ninja)
have ninja || generator=(-G "Unix Makefiles")
cmake_args=(-S . -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DPORTA_BUILD_APPS=OFF
            -DPORTA_BUILD_TESTS=ON -DPORTA_WERROR=OFF)
have nvcc && cmake_args+=(-DPORTA_WITH_CUDA=ON "-DCMAKE_CUDA_COMPILER=$(command -v nvcc)")
[ "$opencl_ok" = 1 ] || cmake_args+=(-DPORTA_WITH_OPENCL=OFF)
# shellcheck disable=SC2206  # extra arguments are split on spaces on purpose
extra=(${PORTA_GPU_CMAKE_ARGS:-})
build_log="$out_dir/build.log"
: >"$build_log"
dropped=()  # backends whose build failed, left out on the next attempt

build() {
  local disable=()
  for b in "${dropped[@]}"; do disable+=("-DPORTA_WITH_${b}=OFF"); done
  say "configuring: cmake ${cmake_args[*]} ${extra[*]} ${disable[*]}"
  cmake "${cmake_args[@]}" "${extra[@]}" "${disable[@]}" >>"$build_log" 2>&1 || return 1
  say "building porta_equivalence_tests with $jobs jobs (log: $build_log)"
  cmake --build "$build_dir" --target porta_equivalence_tests -j "$jobs" >>"$build_log" 2>&1
}

built=0
for attempt in 1 2 3 4; do
  if build; then built=1; break; fi
  # Which backend broke the build? Leave it out and try again, so the others still get tested.
  failing=()
  for b in CUDA VULKAN OPENCL; do
    lower="$(echo "$b" | tr '[:upper:]' '[:lower:]')"
    if grep -E "(FAILED|Error|error).*backends/$lower/|backends/$lower/.*(error|Error)" "$build_log" | grep -q .; then
      [[ " ${dropped[*]} " == *" $b "* ]] || failing+=("$b")
    fi
  done
  if [ ${#failing[@]} -eq 0 ]; then break; fi
  say "attempt $attempt: the build of ${failing[*]} failed; retrying without it (see $build_log)"
  dropped+=("${failing[@]}")
  echo "===== retry without ${dropped[*]} =====" >>"$build_log"
done
grep -E "PortaSLAM: (backend|OpenCV|tests)" "$build_log" | tail -8 | sed 's/^-- /  /'
if [ "$built" != 1 ]; then
  say "BUILD FAILED (last 40 lines of $build_log):"
  tail -40 "$build_log"
  exit 1
fi
binary="$build_dir/tests/porta_equivalence_tests"
record "backends of this build on this machine:"
"$binary" --list-backends | tail -n +2 | tee -a "$machine"

# ---- 5. Run the suite ----------------------------------------------------------------------------
# Every built backend that found a device must run; one that did not is a failure here, not a skip.
require=()
while read -r name state _; do
  name="${name%:}"
  [ "$name" = cpu ] && continue
  [ "$state" = available ] && require+=("$name")
done < <("$binary" --list-backends | tail -n +2)
export PORTA_EQUIVALENCE_SUMMARY="$out_dir/summary.md"
PORTA_EQUIVALENCE_REQUIRE="$(IFS=,; echo "${require[*]}")"
export PORTA_EQUIVALENCE_REQUIRE
say "running the equivalence suite (backends with a device: ${require[*]:-none}); log: $out_dir/equivalence.log"
start=$(date +%s)
"$binary" "--gtest_output=xml:$out_dir/equivalence.xml" >"$out_dir/equivalence.log" 2>&1
status=$?
elapsed=$(( $(date +%s) - start ))

# ---- 5b. The kernels of CPU devices, on this GPU's drivers ---------------------------------------
# vulkan and opencl run other kernels on CPU devices (lavapipe, PoCL: blur, FAST and culling per row
# or per cell, docs/ARCHITECTURE.md); CI proves them on those, this run on NVIDIA's compilers too.
# PORTA_GPU_CPU_PATHS=off leaves it out.
cpu_paths_status=0
if [ "${PORTA_GPU_CPU_PATHS:-on}" = on ]; then
  say "again with the kernels of CPU devices (PORTA_VULKAN_WORK_GROUPS=off PORTA_OPENCL_WORK_GROUPS=off); log: $out_dir/equivalence-cpu-paths.log"
  PORTA_EQUIVALENCE_SUMMARY="$out_dir/summary-cpu-paths.md" PORTA_VULKAN_WORK_GROUPS=off PORTA_OPENCL_WORK_GROUPS=off \
    "$binary" "--gtest_output=xml:$out_dir/equivalence-cpu-paths.xml" >"$out_dir/equivalence-cpu-paths.log" 2>&1
  cpu_paths_status=$?
  [ "$status" = 0 ] && status=$cpu_paths_status
fi

# ---- 6. Report -----------------------------------------------------------------------------------
{
  echo "# PortaSLAM equivalence on $(hostname)"
  echo
  echo '```'
  cat "$machine"
  echo '```'
  echo
  [ ${#dropped[@]} -gt 0 ] && echo "**Build failed for: ${dropped[*]}** (left out; see build.log)" && echo
  sed -n '/^| kernel/,$p' "$out_dir/summary.md" 2>/dev/null
  echo
  if [ -f "$out_dir/summary-cpu-paths.md" ]; then
    echo "With the kernels of CPU devices (work groups off; exit status $cpu_paths_status):"
    echo
    sed -n '/^| kernel/,$p' "$out_dir/summary-cpu-paths.md"
    echo
  fi
  echo "suite exit status $status after ${elapsed} s; finished $(date -u '+%Y-%m-%d %H:%M:%S UTC')"
} >"$out_dir/report.md"

echo
grep -E "^\[  FAILED  \]" "$out_dir/equivalence.log" | head -40
[ -f "$out_dir/equivalence-cpu-paths.log" ] && grep -E "^\[  FAILED  \]" "$out_dir/equivalence-cpu-paths.log" | head -40
echo
echo "==== PortaSLAM equivalence on $(hostname), $(date -u '+%Y-%m-%d %H:%M UTC') ===="
nvidia-smi -L 2>/dev/null
[ ${#dropped[@]} -gt 0 ] && echo "BUILD FAILED for: ${dropped[*]} (left out; see $build_log)"
sed -n '/^| kernel/,$p' "$out_dir/summary.md" 2>/dev/null || tail -30 "$out_dir/equivalence.log"
if [ -f "$out_dir/summary-cpu-paths.md" ]; then
  echo "-- with the kernels of CPU devices (work groups off): exit status $cpu_paths_status"
  sed -n '/^| kernel/,$p' "$out_dir/summary-cpu-paths.md"
fi
grep -E "^REQUIRED BACKEND NOT RUN" "$out_dir/equivalence.log"
echo "suite: exit status $status in ${elapsed} s; results in $out_dir (report.md, equivalence.log)"

if [ "$status" = 77 ]; then say "no backend under test could run on this machine"; exit 1; fi
if [ ${#dropped[@]} -gt 0 ]; then exit 1; fi
[ "$status" = 0 ]
