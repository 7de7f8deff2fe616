# Cross-compiles the probe firmware for the board (Debian 12 arm64, ARMv8-A) with Debian's cross
# compiler against the sysroot scripts/arm64-sysroot.sh assembles. Tests run under qemu-aarch64.
# Usage: cmake -DCMAKE_TOOLCHAIN_FILE=cmake/aarch64-linux-gnu.cmake -DMLP_ARM64_SYSROOT=<dir> ...
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)

if(NOT MLP_ARM64_SYSROOT)
  set(MLP_ARM64_SYSROOT "$ENV{MLP_ARM64_SYSROOT}")
endif()
if(NOT IS_DIRECTORY "${MLP_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu")
  message(FATAL_ERROR "MLP_ARM64_SYSROOT (${MLP_ARM64_SYSROOT}) is not an arm64 sysroot: "
                      "run scripts/arm64-sysroot.sh")
endif()
# Try-compiles see the variable too.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES MLP_ARM64_SYSROOT)

# libc comes with the cross compiler (/usr/aarch64-linux-gnu); everything else from the sysroot.
# Not CMAKE_SYSROOT: that would move libc's headers and crt files there too.
set(CMAKE_FIND_ROOT_PATH "${MLP_ARM64_SYSROOT}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(_mlp_libdirs "${MLP_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu"
                 "${MLP_ARM64_SYSROOT}/lib/aarch64-linux-gnu")
# The sysroot's headers (Boost, zstd, OpenSSL's per-architecture configuration) after the
# cross compiler's own.
set(CMAKE_CXX_FLAGS_INIT "-idirafter ${MLP_ARM64_SYSROOT}/usr/include/aarch64-linux-gnu \
-idirafter ${MLP_ARM64_SYSROOT}/usr/include")
set(CMAKE_C_FLAGS_INIT "${CMAKE_CXX_FLAGS_INIT}")
set(_mlp_link "")
foreach(dir IN LISTS _mlp_libdirs)
  string(APPEND _mlp_link " -L${dir} -Wl,-rpath-link,${dir}")
endforeach()
set(CMAKE_EXE_LINKER_FLAGS_INIT "${_mlp_link}")
set(CMAKE_SHARED_LINKER_FLAGS_INIT "${_mlp_link}")

# pkg-config (zstd) reads the sysroot's .pc files and prefixes their paths with it.
set(ENV{PKG_CONFIG_LIBDIR}
    "${MLP_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu/pkgconfig:${MLP_ARM64_SYSROOT}/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_SYSROOT_DIR} "${MLP_ARM64_SYSROOT}")

# ctest (and gtest_discover_tests at build time) run the aarch64 programs under user-mode qemu,
# which finds the board's loader and libraries under the sysroot.
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64 -L "${MLP_ARM64_SYSROOT}")
