#!/usr/bin/env bash
# The aarch64 job (the Jetson's CPU; docs/RELIABILITY.md, "aarch64"): cross-compiles the engine, the
# cpu backend, the SLAM libraries (without OpenCV, as on the GPU machine), the portaslam program
# and the unit and SLAM test programs with Debian's g++-aarch64-linux-gnu
# (cmake/toolchains/aarch64-linux-gnu.cmake), then
#  1. runs the unit and SLAM tests under qemu-aarch64 (ctest -L 'unit|slam'), and
#  2. runs `portaslam features --dump` on the same stereo pairs with the x86-64 build and with the
#     aarch64 build under qemu, and requires the same keypoints, descriptors and stereo matches,
#     byte for byte: a rendered 1242x375 street pair, and the real ../shared/data pairs when present.
# Exits non-zero on a build failure, a failed test or any difference, naming what differed.
# Called by ci/test.sh (PORTA_CROSS=off there skips it). Run ci/setup.sh first: it installs the
# cross compiler and qemu, and ci/setup-aarch64.sh makes the arm64 sysroot.
#
# Settings (environment):
#   PORTA_AARCH64_BUILD_DIR  the cross build (default build-aarch64)
#   PORTA_X86_BUILD_DIR      the x86-64 build to compare against: ci/test.sh passes its own; default
#                            build-x86, configured here without the GPU backends when absent
#   PORTA_AARCH64_SYSROOT    the arm64 sysroot (default .cross-aarch64/sysroot)
#   PORTA_CROSS_TESTS        ctest label regex run under qemu (default 'unit|slam')
#   PORTA_JOBS               parallel jobs (default 2); PORTA_DATA_DIR: the real data (../shared/data)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

jobs="${PORTA_JOBS:-2}"
cross_dir="${PORTA_AARCH64_BUILD_DIR:-build-aarch64}"
x86_dir="${PORTA_X86_BUILD_DIR:-build-x86}"
sysroot="$(cd "${PORTA_AARCH64_SYSROOT:-.cross-aarch64/sysroot}" 2>/dev/null && pwd || true)"
labels="${PORTA_CROSS_TESTS:-unit|slam}"
data="${PORTA_DATA_DIR:-../shared/data}"
say() { echo "cross-aarch64: $*"; }
fail() { echo "cross-aarch64: FAILED: $*" >&2; exit 1; }

for tool in aarch64-linux-gnu-g++ qemu-aarch64; do
  command -v "$tool" >/dev/null || fail "$tool not found (run ci/setup.sh: it installs g++-aarch64-linux-gnu and qemu-user)"
done
[ -n "$sysroot" ] && [ -d "$sysroot/usr/lib/aarch64-linux-gnu" ] ||
  fail "no arm64 sysroot at ${PORTA_AARCH64_SYSROOT:-.cross-aarch64/sysroot} (run ci/setup.sh or ci/setup-aarch64.sh)"
export PORTA_AARCH64_SYSROOT="$sysroot"  # the toolchain file reads it

# ---- 1. Cross build -------------------------------------------------------------------------------
start=$SECONDS
say "configuring $cross_dir (aarch64, cpu backend only, no OpenCV)"
mkdir -p "$cross_dir"
cmake -S . -B "$cross_dir" -G Ninja -DCMAKE_TOOLCHAIN_FILE="$PWD/cmake/toolchains/aarch64-linux-gnu.cmake" \
  -DPORTA_WERROR=ON -DPORTA_WITH_CUDA=OFF -DPORTA_WITH_VULKAN=OFF -DPORTA_WITH_OPENCL=OFF -DPORTA_BUILD_PYTHON=OFF >"$cross_dir/configure.log" 2>&1 ||
  { tail -30 "$cross_dir/configure.log" >&2; fail "configuring $cross_dir (log: $cross_dir/configure.log)"; }
# The test programs pull in every library: engine, cpu backend, slam_core, optim, slam, dataset,
# render, eval. The equivalence suite is left out: with no GPU backend it has nothing to compare.
cmake --build "$cross_dir" -j "$jobs" --target portaslam porta_unit_tests porta_no_opencv_tests porta_slam_tests ||
  fail "cross build in $cross_dir (the compiler's messages are above)"
for f in "$cross_dir/apps/portaslam" "$cross_dir/tests/porta_unit_tests"; do
  machine="$(aarch64-linux-gnu-readelf -h "$f" | sed -n 's/^ *Machine: *//p')"
  [ "$machine" = AArch64 ] || fail "$f is not an aarch64 program (ELF machine: ${machine:-unreadable})"
done
build_s=$((SECONDS - start))
say "cross build: ${build_s} s"

# ---- 2. Tests under qemu --------------------------------------------------------------------------
start=$SECONDS
unset PORTA_EQUIVALENCE_REQUIRE  # no GPU backend in this build
ctest --test-dir "$cross_dir" --output-on-failure --no-tests=error -j "$jobs" -L "^($labels)$" ||
  fail "tests under qemu-aarch64 (ctest --test-dir $cross_dir -L '^($labels)\$')"
tests_s=$((SECONDS - start))
say "tests under qemu-aarch64: ${tests_s} s"

# ---- 3. The cpu frontend's output, x86-64 against aarch64 -----------------------------------------
start=$SECONDS
if [ ! -f "$x86_dir/CMakeCache.txt" ]; then
  say "configuring $x86_dir (x86-64 reference, cpu backend only)"
  mkdir -p "$x86_dir"
  cmake -S . -B "$x86_dir" -G Ninja -DPORTA_WERROR=ON -DPORTA_WITH_CUDA=OFF -DPORTA_WITH_VULKAN=OFF \
    -DPORTA_WITH_OPENCL=OFF -DPORTA_BUILD_PYTHON=OFF >"$x86_dir/configure.log" 2>&1 ||
    { tail -30 "$x86_dir/configure.log" >&2; fail "configuring $x86_dir (log: $x86_dir/configure.log)"; }
fi
cmake --build "$x86_dir" -j "$jobs" --target portaslam || fail "x86-64 build of portaslam in $x86_dir"
x86_program="$x86_dir/apps/portaslam"
arm_program="$cross_dir/apps/portaslam"
# As the toolchain file's CMAKE_CROSSCOMPILING_EMULATOR: the cross compiler's libc, the sysroot's libraries.
lib="$sysroot/usr/lib/aarch64-linux-gnu"
qemu=(qemu-aarch64 -L /usr/aarch64-linux-gnu -E "LD_LIBRARY_PATH=$lib:$lib/atlas:$sysroot/lib/aarch64-linux-gnu")

work="$cross_dir/compare"
rm -rf "$work"
mkdir -p "$work/x86-64" "$work/aarch64"
"$x86_program" render --path street-loop --first 60 --count 1 --size 1242x375 --quiet --out "$work/street" \
  >"$work/render.log" 2>&1 || { cat "$work/render.log" >&2; fail "portaslam render of the 1242x375 street pair"; }
names=(street-1242x375) lefts=("$work/street/image_0/000000.png") rights=("$work/street/image_1/000000.png")
for scene in tsukuba venus; do  # real rectified pairs (Middlebury), where the shared data is present
  d="$data/middlebury/$scene"
  if [ -f "$d/im2.png" ] && [ -f "$d/im6.png" ]; then
    names+=("middlebury-$scene") lefts+=("$d/im2.png") rights+=("$d/im6.png")
  fi
done
[ ${#names[@]} -gt 1 ] || say "no real pairs in $data/middlebury (absent here): the rendered pair only"

# Prints where two dumps first differ: the line number, the section and both lines.
first_difference() {
  local a="$1" b="$2" report line
  report="$(cmp "$a" "$b" 2>&1 || true)"
  case "$report" in  # one file is a prefix of the other: "cmp: EOF on FILE after byte N, line L"
    *EOF*) echo "  one dump ends where the other goes on: $report"; return ;;
  esac
  line="$(sed -n 's/.* line \([0-9]*\).*/\1/p' <<<"$report")"
  local section
  section="$(head -n "$line" "$a" | grep -E '^(left keypoints|right keypoints|matches|image)' | tail -1)"
  echo "  first difference at line $line (section: ${section:-header}):"
  echo "    x86-64:  $(sed -n "${line}p" "$a" | cut -c1-120)"
  echo "    aarch64: $(sed -n "${line}p" "$b" | cut -c1-120)"
}

differences=0
for i in "${!names[@]}"; do
  name="${names[$i]}" left="${lefts[$i]}" right="${rights[$i]}"
  for arch in x86-64 aarch64; do
    if [ "$arch" = x86-64 ]; then runner=("$x86_program"); else runner=("${qemu[@]}" "$arm_program"); fi
    "${runner[@]}" features "$left" "$right" --dump "$work/$arch/$name.txt" --out "$work/$arch/$name.png" \
      >"$work/$arch/$name.log" 2>&1 || { cat "$work/$arch/$name.log" >&2; fail "portaslam features on $name ($arch)"; }
  done
  counts="$(grep -E '^(left keypoints|right keypoints|matches)' "$work/x86-64/$name.txt" | paste -sd, | sed 's/,/, /g')"
  if cmp -s "$work/x86-64/$name.txt" "$work/aarch64/$name.txt"; then
    say "$name: identical keypoints, descriptors and matches ($counts)"
  else
    differences=$((differences + 1))
    echo "cross-aarch64: $name: aarch64 differs from x86-64 (x86-64: $counts;" \
         "aarch64: $(grep -E '^(left keypoints|right keypoints|matches)' "$work/aarch64/$name.txt" | paste -sd, | sed 's/,/, /g'))" >&2
    first_difference "$work/x86-64/$name.txt" "$work/aarch64/$name.txt" >&2
    echo "  dumps: $work/x86-64/$name.txt $work/aarch64/$name.txt" >&2
  fi
done
compare_s=$((SECONDS - start))
[ "$differences" -eq 0 ] || fail "$differences of ${#names[@]} stereo pairs gave different features on aarch64"
say "output check: ${#names[@]} stereo pairs identical on x86-64 and aarch64 (${compare_s} s)"
say "done: build ${build_s} s, tests ${tests_s} s, output check ${compare_s} s"
