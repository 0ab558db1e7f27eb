# Cross-compiling the uavbus core for a Cortex-M4F microcontroller with Debian's gcc-arm-none-eabi and
# libnewlib-arm-none-eabi (newlib-nano, no operating system: nosys.specs stubs the system calls).
#
#   cmake -S examples/mcu -B build-mcu -G Ninja \
#         -DCMAKE_TOOLCHAIN_FILE=cmake/toolchains/arm-none-eabi-cortex-m4.cmake -DUAVBUS_PYTHON=.venv/bin/python
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-none-eabi-gcc)
set(CMAKE_AR arm-none-eabi-ar CACHE FILEPATH "")
set(CMAKE_RANLIB arm-none-eabi-ranlib CACHE FILEPATH "")
set(CMAKE_SIZE arm-none-eabi-size CACHE FILEPATH "")
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

# -fno-short-enums: arm-none-eabi-gcc makes an enum as small as its values (1 byte for most), the host's
# compilers make it an int. A catalogue generated on the host records 4-byte enums (the layout its
# content fingerprints and generated static asserts check), so the target must lay them out the same;
# an enum declared __attribute__((packed)) stays one byte on both.
set(CMAKE_C_FLAGS_INIT "-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16 -fno-short-enums -ffunction-sections -fdata-sections")
# --no-enum-size-warning: newlib's prebuilt objects were built with short enums; none of their enums
# cross into our code (the core uses no newlib function taking or returning an enum).
set(CMAKE_EXE_LINKER_FLAGS_INIT "--specs=nano.specs --specs=nosys.specs -Wl,--gc-sections -Wl,--no-enum-size-warning")

set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
