# Shared by the GPU-machine scripts (ci/gpu-bench.sh, ci/gpu-slam.sh); sourced, not run. Each
# function writes into the caller's OUT_DIR (variable out_dir) and prints with the caller's say().
#   gpu_machine_info           machine.txt: date, commit (PORTA_COMMIT where the tree has no .git),
#                              CPU, GPU, nvcc
#   gpu_register_opencl        NVIDIA's OpenCL ICD for this run, where no .icd file names it
#   gpu_build DIR TARGET ARGS  builds TARGET (Release, every backend this machine supports; a
#                              backend whose build fails is left out and named in machine.txt)
#                              into DIR, with more CMake ARGS; sets `binary` and `left_out`.
have() { command -v "$1" >/dev/null 2>&1; }
if ! have nvcc && [ -x /usr/local/cuda/bin/nvcc ]; then export PATH="/usr/local/cuda/bin:$PATH"; fi

gpu_machine_info() {
  {
    echo "date: $(date -u '+%Y-%m-%d %H:%M:%S UTC'); host $(hostname), $(uname -srm)"
    echo "commit: ${PORTA_COMMIT:-$(git rev-parse --short HEAD 2>/dev/null || echo unknown)$(git diff --quiet 2>/dev/null || echo ' (with local changes)')}"
    echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//'), $(nproc) hardware threads"
    have nvidia-smi && nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader | sed 's/^/gpu: /'
    have nvcc && echo "nvcc: $(nvcc --version | tail -1)"
  } | tee "$out_dir/machine.txt"
}

# NVIDIA's OpenCL is found by the ICD loader only through an .icd file naming the driver's library;
# where none does, a private vendors folder in OUT_DIR serves this run (ci/gpu.sh registers it
# system-wide instead).
gpu_register_opencl() {
  local nvidia_cl
  nvidia_cl="$(ldconfig -p 2>/dev/null | awk '$1 == "libnvidia-opencl.so.1" {print $NF; exit}')"
  if [ -n "$nvidia_cl" ] && ! grep -qs libnvidia-opencl "${OCL_ICD_VENDORS:-/etc/OpenCL/vendors}"/*.icd; then
    mkdir -p "$out_dir/icd-vendors"
    cp /etc/OpenCL/vendors/*.icd "$out_dir/icd-vendors/" 2>/dev/null || true
    echo "libnvidia-opencl.so.1" >"$out_dir/icd-vendors/nvidia.icd"
    export OCL_ICD_VENDORS="$out_dir/icd-vendors"
    echo "opencl: NVIDIA's ICD registered for this run (OCL_ICD_VENDORS=$OCL_ICD_VENDORS)" | tee -a "$out_dir/machine.txt"
  fi
}

gpu_build() {
  local build_dir="$1" target="$2"
  shift 2
  local generator=(-G Ninja)
  have ninja || generator=(-G "Unix Makefiles")
  local cmake_args=(-S . -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DPORTA_BUILD_APPS=ON
                    -DPORTA_BUILD_TESTS=OFF -DPORTA_WERROR=OFF "$@")
  have nvcc && cmake_args+=(-DPORTA_WITH_CUDA=ON "-DCMAKE_CUDA_COMPILER=$(command -v nvcc)")
  # shellcheck disable=SC2206  # extra arguments are split on spaces on purpose
  local extra=(${PORTA_GPU_CMAKE_ARGS:-})
  local build_log="$out_dir/build.log"
  : >"$build_log"
  left_out=()  # backends whose build failed
  local built=0 attempt b lower failing off
  for attempt in 1 2 3 4; do
    off=()
    for b in "${left_out[@]}"; do off+=("-DPORTA_WITH_${b}=OFF"); done
    say "building $target in $build_dir (attempt $attempt${left_out[*]:+, without ${left_out[*]}}); log: $build_log"
    if cmake "${cmake_args[@]}" "${extra[@]}" "${off[@]}" >>"$build_log" 2>&1 &&
       cmake --build "$build_dir" --target "$target" -j "${PORTA_JOBS:-$(nproc)}" >>"$build_log" 2>&1; then
      built=1
      break
    fi
    failing=""
    for b in CUDA VULKAN OPENCL; do
      lower="$(echo "$b" | tr '[:upper:]' '[:lower:]')"
      [[ " ${left_out[*]} " == *" $b "* ]] && continue
      if grep -qE "(FAILED|rror).*backends/$lower/" "$build_log"; then failing="$b"; break; fi
    done
    [ -z "$failing" ] && break
    left_out+=("$failing")
  done
  grep -E "PortaSLAM: (backend|OpenCV|portaslam|Ceres|dataset)" "$build_log" | tail -10 | sed 's/^-- /  /'
  binary="$build_dir/apps/portaslam"
  if [ "$built" != 1 ] || [ ! -x "$binary" ]; then
    say "BUILD FAILED (last 30 lines of $build_log):"
    tail -30 "$build_log"
    grep -q "portaslam program is not built" "$build_log" && say "portaslam needs libpng (libpng-dev) or OpenCV"
    return 1
  fi
  if [ ${#left_out[@]} -gt 0 ]; then
    echo "BUILD FAILED for: ${left_out[*]} (left out; see build.log)" | tee -a "$out_dir/machine.txt"
  fi
  return 0
}
