#!/usr/bin/env bash
# Runs ci/gpu.sh (or another script, e.g. ci/gpu-bench.sh) on a GPU machine that has CUDA and
# the NVIDIA driver but no package manager or network. It unpacks the packages that
# ci/fetch-gpu-deps.sh put in DEPS_DIR: the Vulkan loader
# into / (the driver's ICD needs it on the default library path), the OpenCL ICD loader there too
# when none is installed, the Vulkan headers and glslang into a private prefix; points CMake and
# the loaders at them; and uses DEPS_DIR/data as the real test images. Needs root.
#
#   usage: ci/gpu-carried.sh DEPS_DIR [OUT_DIR [SCRIPT]]
#
# SCRIPT (default ci/gpu.sh, the equivalence suite) is run as `bash SCRIPT OUT_DIR` in that
# environment; ci/gpu-bench.sh there gives the throughput matrix and its Python peer, and
# ci/gpu-slam.sh the whole SLAM on every backend.
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.." || exit 1
deps="$(cd "${1:?usage: ci/gpu-carried.sh DEPS_DIR [OUT_DIR [SCRIPT]]}" && pwd)"
out="${2:-gpu-results}"
script="${3:-ci/gpu.sh}"
if [ ! -f "$script" ]; then
  echo "gpu-carried.sh: no script '$script' (paths are relative to the repository root)" >&2
  exit 1
fi
prefix=/tmp/porta-deps
mkdir -p "$prefix"

have_opencl_loader() { ldconfig -p 2>/dev/null | grep -q 'libOpenCL.so'; }
opencl_loader_missing=0
have_opencl_loader || opencl_loader_missing=1
for f in "$deps"/debs/*.deb; do
  case "$(basename "$f")" in
    # The Vulkan loader and GLVND, where the NVIDIA ICD's dlopen finds them.
    libvulkan1_* | libglvnd0_* | libgl1_* | libglx0_* | libegl1_* | libgles2_* | libopengl0_*) dpkg -x "$f" / ;;
    ocl-icd-*) [ "$opencl_loader_missing" = 1 ] && dpkg -x "$f" / ;;  # only where none is installed
    *) dpkg -x "$f" "$prefix" ;;
  esac
done
ldconfig 2>/dev/null || true

# NVIDIA's Vulkan ICD manifest, when the driver mounts it outside the loader's search path.
for icd in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json /usr/share/vulkan/icd.d/nvidia_icd.json \
           /etc/vulkan/icd.d/nvidia_icd.json; do
  if [ -f "$icd" ]; then export VK_DRIVER_FILES="$icd"; break; fi
done
echo "gpu-carried.sh: Vulkan ICD manifest: ${VK_DRIVER_FILES:-none found (the loader searches its defaults)}"
[ -n "${VK_DRIVER_FILES:-}" ] && grep -h library_path "$VK_DRIVER_FILES"
if [ -d /usr/local/nvidia/share/glvnd/egl_vendor.d ]; then
  export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
fi

cmake_args=(-DVulkan_INCLUDE_DIR="$prefix/usr/include"
            -DVulkan_GLSLANG_VALIDATOR_EXECUTABLE="$prefix/usr/bin/glslangValidator")
if [ -e /usr/lib/x86_64-linux-gnu/libvulkan.so.1 ]; then
  cmake_args+=(-DVulkan_LIBRARY=/usr/lib/x86_64-linux-gnu/libvulkan.so.1)
fi
# Eigen and Ceres (with SuiteSparse, glog, gflags, ATLAS's BLAS/LAPACK, which Debian's libceres3
# links) from the private prefix: CMake finds their packages there, the linker and the program
# their libraries (BLAS and LAPACK in the atlas/ subfolder Debian's alternatives would link from).
lib="$prefix/usr/lib/x86_64-linux-gnu"
export CMAKE_PREFIX_PATH="$prefix/usr${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}"
export LD_LIBRARY_PATH="$lib:$lib/atlas${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
# Ceres's exported target names the BLAS/LAPACK development links of the machine it was built on
# (/usr/lib/x86_64-linux-gnu/lib{lapack,blas,f77blas,atlas}.so): libceres.so.3 records them as
# needed libraries already, so they are dropped from the link line.
ceres_targets="$lib/cmake/Ceres/CeresTargets.cmake"
[ -f "$ceres_targets" ] && sed -i 's|;/usr/lib/x86_64-linux-gnu/lib[a-z0-9_]*\.so||g' "$ceres_targets"
[ -d "$prefix/usr/include/eigen3" ] && cmake_args+=(-DEigen3_DIR="$prefix/usr/share/eigen3/cmake")
# glog's package adds the absolute /usr/share/glog/cmake (its FindUnwind.cmake) to the module path
# (inside Ceres's package, which sets the module path itself): point it into the prefix.
glog_modules="$lib/cmake/glog/glog-modules.cmake"
[ -f "$glog_modules" ] && sed -i "s|\"/usr/share/glog/cmake\"|\"$prefix/usr/share/glog/cmake\"|" "$glog_modules"
export PORTA_GPU_CMAKE_ARGS="${cmake_args[*]} ${PORTA_GPU_CMAKE_ARGS:-}"
[ -d "$deps/data" ] && export PORTA_DATA_DIR="$deps/data"
exec bash "$script" "$out"
