# Cross-compiling PortaSLAM for aarch64 Linux (the Jetson's CPU) on an x86-64 Debian 12 machine
# with Debian's g++-aarch64-linux-gnu: its own arm64 libc and libstdc++ live in
# /usr/aarch64-linux-gnu. Every other arm64 library (libpng, Ceres and its libraries, GoogleTest,
# Eigen) comes from the private sysroot that ci/setup-aarch64.sh unpacks: .cross-aarch64/sysroot
# beside this checkout's root, or $PORTA_AARCH64_SYSROOT. Tests run under qemu-aarch64 (ctest
# uses CMAKE_CROSSCOMPILING_EMULATOR, and so does gtest_discover_tests). ci/cross-aarch64.sh uses it:
#
#   cmake -S . -B build-aarch64 -DCMAKE_TOOLCHAIN_FILE=cmake/toolchains/aarch64-linux-gnu.cmake
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
# Debian's multiarch folder names (usr/lib/aarch64-linux-gnu, .../cmake/<Package>): CMake does not
# infer it from a cross compiler whose libraries live in /usr/aarch64-linux-gnu/lib.
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)

# An environment variable, not a cache entry: try_compile re-reads this file in a fresh project
# where the caller's cache entries are absent but the environment is not.
if(DEFINED ENV{PORTA_AARCH64_SYSROOT} AND NOT "$ENV{PORTA_AARCH64_SYSROOT}" STREQUAL "")
  get_filename_component(porta_sysroot "$ENV{PORTA_AARCH64_SYSROOT}" ABSOLUTE)
else()
  get_filename_component(porta_sysroot "${CMAKE_CURRENT_LIST_DIR}/../../.cross-aarch64/sysroot" ABSOLUTE)
endif()
if(NOT EXISTS "${porta_sysroot}/usr/lib/aarch64-linux-gnu")
  message(FATAL_ERROR "aarch64 toolchain: no arm64 sysroot at ${porta_sysroot} (run ci/setup-aarch64.sh, "
                      "or set PORTA_AARCH64_SYSROOT to the folder it made)")
endif()
set(porta_cross_libs "${porta_sysroot}/usr/lib/aarch64-linux-gnu")

# Packages, headers and libraries only from the arm64 trees, never the host's amd64 /usr; programs
# (the code generators of the build) from the host.
set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu "${porta_sysroot}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# The linker follows shared libraries' own needs (libceres.so.3 -> libglog.so.1 -> ...) through
# -rpath-link; BLAS and LAPACK are in atlas/, where Debian's alternatives would point.
set(porta_rpath_link "${porta_cross_libs}:${porta_cross_libs}/atlas:${porta_sysroot}/lib/aarch64-linux-gnu")
foreach(kind EXE SHARED MODULE)
  set(CMAKE_${kind}_LINKER_FLAGS_INIT "-Wl,-rpath-link,${porta_rpath_link}")
endforeach()

# qemu-aarch64 loads the cross compiler's arm64 libc (-L) and finds the sysroot's libraries
# through the guest's LD_LIBRARY_PATH (-E: set for the emulated program only, not for qemu).
find_program(PORTA_QEMU_AARCH64 NAMES qemu-aarch64 qemu-aarch64-static)
if(PORTA_QEMU_AARCH64)
  set(CMAKE_CROSSCOMPILING_EMULATOR "${PORTA_QEMU_AARCH64};-L;/usr/aarch64-linux-gnu;-E;LD_LIBRARY_PATH=${porta_rpath_link}")
endif()
