# Cross build for 64-bit ARM Linux with Debian's cross compiler and multiarch libraries (preset
# aarch64; scripts/install-deps.sh --arm64 installs g++-aarch64-linux-gnu, libhwy-dev:arm64,
# libgtest-dev:arm64 and qemu-user-static). The test programs run under qemu-user with `-cpu max`,
# which offers NEON, SVE and SVE2, so that Highway's dispatch and the tests' target loops run each.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# Libraries and CMake packages of the target: /usr/lib/aarch64-linux-gnu (CMake searches the
# compiler's multiarch folder first); pkg-config reads the target's .pc files only.
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")
# ctest and gtest_discover_tests run the programs through qemu (binfmt_misc need not be registered,
# as in a container): -L takes the loader of the cross toolchain's C library, and LD_LIBRARY_PATH
# the rest of that library, so that the loader never meets the multiarch libc6:arm64 of
# /lib/aarch64-linux-gnu, another build (a loader and a C library of two builds hang in
# pthread_create). Highway's arm64 library still comes from /lib/aarch64-linux-gnu.
find_program(MCTSTEREO_QEMU_AARCH64 qemu-aarch64-static REQUIRED)
set(CMAKE_CROSSCOMPILING_EMULATOR
    "${MCTSTEREO_QEMU_AARCH64};-L;/usr/aarch64-linux-gnu;-E;LD_LIBRARY_PATH=/usr/aarch64-linux-gnu/lib;-cpu;max")
