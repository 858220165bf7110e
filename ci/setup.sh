#!/usr/bin/env bash
# Installs every build and test dependency of PortaSLAM from Debian 12 packages, non-interactively.
# Safe to re-run. CUDA is not installed here: the build uses it when `nvcc` is already on PATH.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  clang libclang-rt-dev
  libeigen3-dev libceres-dev
  libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev
  libopencv-features2d-dev libopencv-calib3d-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libpng-dev
  python3-dev python3-venv python3-numpy python3-pytest pybind11-dev
  libvulkan-dev mesa-vulkan-drivers glslang-tools spirv-tools vulkan-tools
  opencl-headers ocl-icd-opencl-dev pocl-opencl-icd clinfo
)

sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages already installed"
  exit 0
fi

echo "setup: installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "setup: done"
