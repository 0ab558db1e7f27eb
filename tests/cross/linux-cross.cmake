# Toolchain for tests/cross/run.sh: a Debian cross compiler for another Linux target, its programs run
# under qemu-user. run.sh passes the target with -DUB_CROSS_TRIPLE (s390x-linux-gnu: 64-bit big-endian;
# arm-linux-gnueabihf: 32-bit, unsigned char) and -DUB_CROSS_SYSROOT, a directory where it unpacked the
# target's cmocka and libsodium from Debian's packages (the packages are not installed: the machine's dpkg
# keeps one architecture).
set(CMAKE_SYSTEM_NAME Linux)
if(NOT UB_CROSS_TRIPLE)
  set(UB_CROSS_TRIPLE "$ENV{UB_CROSS_TRIPLE}")
  set(UB_CROSS_SYSROOT "$ENV{UB_CROSS_SYSROOT}")
endif()
string(REGEX MATCH "^[^-]+" CMAKE_SYSTEM_PROCESSOR "${UB_CROSS_TRIPLE}")
set(CMAKE_C_COMPILER ${UB_CROSS_TRIPLE}-gcc)
# try_compile() projects read this file again: the target comes from the environment there.
set(ENV{UB_CROSS_TRIPLE} "${UB_CROSS_TRIPLE}")
set(ENV{UB_CROSS_SYSROOT} "${UB_CROSS_SYSROOT}")

if(CMAKE_SYSTEM_PROCESSOR STREQUAL "arm")
  set(UB_QEMU qemu-arm)
else()
  set(UB_QEMU qemu-${CMAKE_SYSTEM_PROCESSOR})
endif()
# 64-bit file offsets, as 32-bit Linux distributions build (a no-op on 64-bit targets). Without it a 32-bit
# readdir() under qemu-user on a 64-bit kernel stops early with EOVERFLOW (ext4's 64-bit directory cookies):
# test_nodecfg read 0 of its 60+ bad-config cases on armhf. The runtime itself copes without (a log file that
# reaches 2 GiB gets EFBIG and rotates), but a 32-bit product build should set it too.
set(CMAKE_C_FLAGS_INIT "-D_FILE_OFFSET_BITS=64")

# The target's C library and loader come with the cross compiler (libc6-dev-<arch>-cross, /usr/<triple>).
set(CMAKE_CROSSCOMPILING_EMULATOR ${UB_QEMU} -L /usr/${UB_CROSS_TRIPLE})

# cmocka and libsodium of the target: headers, pkg-config files and libraries from the unpacked packages;
# the programs find the shared ones at run time through their build RPATH.
set(CMAKE_FIND_ROOT_PATH ${UB_CROSS_SYSROOT} /usr/${UB_CROSS_TRIPLE})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
set(ENV{PKG_CONFIG_LIBDIR} "${UB_CROSS_SYSROOT}/usr/lib/${UB_CROSS_TRIPLE}/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")
set(ENV{PKG_CONFIG_SYSROOT_DIR} "${UB_CROSS_SYSROOT}")
