#!/usr/bin/env bash
# Installs every build and test dependency of PortaSLAM from Debian 12 packages, non-interactively.
# Safe to re-run. CUDA is not installed here: the build uses it when `nvcc` is already on PATH.
# The aarch64 job (ci/cross-aarch64.sh) needs the cross compiler and qemu-user from here, and an
# arm64 sysroot that ci/setup-aarch64.sh makes at the end; PORTA_CROSS=off leaves all three out.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

packages=(
  build-essential cmake ninja-build pkg-config git
  clang libclang-rt-dev
  libeigen3-dev libceres-dev
  libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev
  libopencv-features2d-dev libopencv-calib3d-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libpng-dev libdeflate-dev
  python3-dev python3-venv python3-numpy python3-pytest pybind11-dev
  libvulkan-dev mesa-vulkan-drivers glslang-tools spirv-tools vulkan-tools
  opencl-headers ocl-icd-opencl-dev pocl-opencl-icd clinfo
)
cross=1
[ "${PORTA_CROSS:-on}" = off ] && cross=0
if [ "$cross" = 1 ]; then
  packages+=(g++-aarch64-linux-gnu qemu-user)  # qemu-user: qemu-aarch64 runs the tests, no binfmt needed
fi

sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages already installed"
else
  echo "setup: installing ${#missing[@]} packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
# The arm64 libraries, unpacked into a folder of this checkout (no root needed, dpkg untouched).
if [ "$cross" = 1 ]; then bash ci/setup-aarch64.sh; fi
echo "setup: done"
