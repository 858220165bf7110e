#!/usr/bin/env bash
# Prepares a folder to carry to a GPU machine that cannot install packages itself (no network, no
# apt): the Debian 12 packages ci/gpu.sh needs beyond CUDA (the Vulkan loader and headers,
# glslang, the OpenCL ICD loader, the GLVND libraries NVIDIA's Vulkan driver loads; Eigen, and
# Ceres with its libraries for the SLAM back end of ci/gpu-slam.sh; Google Benchmark for its local BA
# benchmark; libdeflate, with which imageio/ reads gray PNG files three times as fast as libpng), the few real images of
# ../shared/data the equivalence suite reads, and KITTI 00's ground-truth poses and times (the
# path ci/gpu-slam.sh renders). Run it on a Debian 12 (amd64) machine with network access; then, on the GPU machine, run
# `bash ci/gpu-carried.sh DEPS_DIR [OUT_DIR]`.
#
#   usage: ci/fetch-gpu-deps.sh [DEPS_DIR]     (default: .deps, which .gitignore ignores)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

deps="${1:-.deps}"
mkdir -p "$deps/debs" "$deps/data"
lists="$(mktemp -d)"
opts=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 "-oDir::State::Lists=$lists")
mkdir -p "$lists/partial"
apt-get "${opts[@]}" update -qq
(cd "$deps/debs" && apt-get "${opts[@]}" download \
  libvulkan1 libvulkan-dev glslang-tools ocl-icd-libopencl1 ocl-icd-opencl-dev \
  libglvnd0 libgl1 libglx0 libegl1 libgles2 libopengl0 \
  libeigen3-dev libceres-dev libceres3 libgoogle-glog-dev libgoogle-glog0v6 libgflags-dev libgflags2.2 \
  libunwind8 libunwind-dev liblzma-dev libsuitesparse-dev libcholmod3 libspqr2 libcxsparse3 libsuitesparseconfig5 libamd2 libcamd2 \
  libccolamd2 libcolamd2 libmetis5 libbtf1 libklu1 libldl2 librbio2 libumfpack5 libsliplu1 libmongoose2 \
  libatlas3-base libgfortran5 \
  libbenchmark-dev libbenchmark1debian libdeflate-dev libdeflate0)  # GLVND: NVIDIA's Vulkan ICD needs it; then Ceres (SLAM); Google Benchmark; libdeflate
rm -rf "$lists"

data="${PORTA_DATA_DIR:-../shared/data}"
for f in middlebury/tsukuba/im2.png middlebury/tsukuba/im6.png \
         oxford-affine/bikes/img1.png oxford-affine/bikes/img2.png \
         kitti07-left-head/image_0/000000.png kitti07-left-head/image_0/000001.png; do
  if [ -f "$data/$f" ]; then mkdir -p "$deps/data/$(dirname "$f")"; cp "$data/$f" "$deps/data/$f"; fi
done
for f in gt-trajectories/kitti00_poses.txt gt-trajectories/kitti00_times.txt \
         peer-results/orbslam2-kitti00-render-1000/rendered_input.md5 \
         peer-results/orbslam2-kitti00-render-1000/trajectory_kitti.txt; do
  if [ -f "$data/$f" ]; then mkdir -p "$deps/data/$(dirname "$f")"; cp "$data/$f" "$deps/data/$f"; fi
done
for cam in cam0 cam1; do  # the first two frames of each EuRoC camera
  src="$data/euroc-v101-head/mav0/$cam/data"
  if [ -d "$src" ]; then
    mkdir -p "$deps/data/euroc-v101-head/mav0/$cam/data"
    find "$src" -name '*.png' | sort | head -2 | xargs -I{} cp {} "$deps/data/euroc-v101-head/mav0/$cam/data/"
  fi
done
du -sh "$deps"
