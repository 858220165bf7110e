#!/usr/bin/env bash
# The aarch64 (Jetson CPU) half of ci/setup.sh: a private arm64 sysroot for ci/cross-aarch64.sh.
# Debian's arm64 -dev packages (libpng, Ceres and its libraries, GoogleTest, Eigen) are fetched
# with `apt-get download` from arm64 package lists kept in a private folder, and unpacked with
# `dpkg -x` into SYSROOT. The system's dpkg is never told about arm64: multiarch co-installation
# of -dev packages conflicts with the amd64 ones that ci/setup.sh installs (same header paths,
# versions that must match exactly), and a half-done multiarch install breaks later apt runs.
# The cross compiler (g++-aarch64-linux-gnu, with its own arm64 libc and libstdc++) and
# qemu-aarch64 come from ci/setup.sh's ordinary install.
#
#   usage: ci/setup-aarch64.sh            (SYSROOT: .cross-aarch64/sysroot, or $PORTA_AARCH64_SYSROOT)
#
# Idempotent: a stamp in SYSROOT records the package list; when it matches, nothing is fetched.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

sysroot="${PORTA_AARCH64_SYSROOT:-.cross-aarch64/sysroot}"

# What the cross build links (cmake/toolchains/aarch64-linux-gnu.cmake), with every library those
# need at link and run time that the cross compiler's own arm64 libc/libstdc++ do not provide.
# Ceres's closure is the one ci/fetch-gpu-deps.sh carries for amd64.
packages=(
  libpng-dev libpng16-16 zlib1g-dev zlib1g libdeflate-dev libdeflate0
  libgtest-dev libgmock-dev
  libeigen3-dev
  libceres-dev libceres3 libgoogle-glog-dev libgoogle-glog0v6 libgflags-dev libgflags2.2
  libunwind8 libunwind-dev liblzma-dev liblzma5
  libsuitesparse-dev libcholmod3 libspqr2 libcxsparse3 libsuitesparseconfig5 libamd2 libcamd2
  libccolamd2 libcolamd2 libmetis5 libmetis-dev libbtf1 libklu1 libldl2 librbio2 libumfpack5 libsliplu1 libmongoose2
  libgmp10 libmpfr6
  libatlas3-base libgfortran5
)
stamp="$sysroot/.porta-packages"
wanted="$(printf '%s\n' "${packages[@]}")"
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$wanted" ]; then
  echo "setup-aarch64: arm64 sysroot already in $sysroot (${#packages[@]} packages)"
  exit 0
fi

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# Private lists and caches: the system's amd64 apt state (lists, pkgcache.bin) stays untouched.
mkdir -p "$work/lists/partial" "$work/cache/archives/partial" "$work/debs"
opts=(-q -oAPT::Architecture=arm64 -oAPT::Architectures=arm64 "-oDir::State::Lists=$work/lists"
      "-oDir::Cache=$work/cache" -oDir::State::Status=/dev/null -oAPT::Sandbox::User=root)
echo "setup-aarch64: fetching Debian's arm64 package lists"
if ! apt-get "${opts[@]}" update >"$work/update.log" 2>&1; then
  cat "$work/update.log" >&2
  echo "setup-aarch64: apt-get update for arm64 failed (see above): check the network and /etc/apt/sources.list*" >&2
  exit 1
fi
echo "setup-aarch64: downloading ${#packages[@]} arm64 packages"
if ! (cd "$work/debs" && apt-get "${opts[@]}" download "${packages[@]}") >"$work/download.log" 2>&1; then
  cat "$work/download.log" >&2
  echo "setup-aarch64: apt-get download of the arm64 packages failed (see above)" >&2
  exit 1
fi

rm -rf "$sysroot"
mkdir -p "$sysroot"
for deb in "$work"/debs/*.deb; do dpkg -x "$deb" "$sysroot"; done
sysroot_abs="$(cd "$sysroot" && pwd)"

# Absolute symbolic links (e.g. a -dev package's libfoo.so -> /lib/aarch64-linux-gnu/libfoo.so.1)
# would point into the host's amd64 system: make them point inside the sysroot (relatively, so
# that the folder can move).
while IFS= read -r link; do
  target="$(readlink "$link")"
  case "$target" in /*) ln -sfnr "$sysroot_abs$target" "$link" ;; esac
done < <(find "$sysroot_abs" -type l)

lib="$sysroot_abs/usr/lib/aarch64-linux-gnu"
# The development links to BLAS and LAPACK that Debian's alternatives would make (ATLAS's, which
# libceres3 uses): Ceres's package looks for them when it finds SuiteSparse.
ln -sfn atlas/libblas.so.3 "$lib/libblas.so"
ln -sfn atlas/liblapack.so.3 "$lib/liblapack.so"
# Ceres's exported target names BLAS/LAPACK development links by their absolute build-machine
# paths; libceres.so.3 records them as needed libraries already (resolved from atlas/, which
# Debian's alternatives would link), so they are dropped from the link line, as in ci/gpu-carried.sh.
sed -i 's|;/usr/lib/aarch64-linux-gnu/lib[a-z0-9_]*\.so||g' "$lib/cmake/Ceres/CeresTargets.cmake"
# glog's package adds the absolute /usr/share/glog/cmake to CMake's module path, which is the
# host's amd64 copy (with a FindUnwind.cmake the arm64 package lacks): keep the search in the sysroot.
sed -i 's|"/usr/share/glog/cmake"|"${CMAKE_CURRENT_LIST_DIR}/../../../../share/glog/cmake"|' \
  "$lib/cmake/glog/glog-modules.cmake"

printf '%s\n' "$wanted" >"$stamp"
echo "setup-aarch64: arm64 sysroot ready in $sysroot ($(du -sh "$sysroot" | cut -f1), ${#packages[@]} packages)"
