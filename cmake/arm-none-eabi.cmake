# Toolchain: Cortex-M4F (mps2-an386 under qemu-system-arm), newlib with
# semihosting (rdimon). Used by tools/fw_targets.sh with -DAFM_FIRMWARE_ONLY=ON.
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-none-eabi-gcc)
set(CMAKE_CXX_COMPILER arm-none-eabi-g++)
set(CMAKE_ASM_COMPILER arm-none-eabi-gcc)
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

set(AFM_ARM_CPU_FLAGS "-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16")
set(CMAKE_C_FLAGS_INIT "${AFM_ARM_CPU_FLAGS} -ffunction-sections -fdata-sections")
set(CMAKE_CXX_FLAGS_INIT "${AFM_ARM_CPU_FLAGS} -ffunction-sections -fdata-sections")
# The board's startup and linker script are in board/ (startup.c,
# mps2_an386.ld). Set in the cache at every configure, not only the first,
# so that a build tree made before the script moved there links with it.
set(CMAKE_EXE_LINKER_FLAGS
    "${AFM_ARM_CPU_FLAGS} --specs=rdimon.specs -T${CMAKE_CURRENT_LIST_DIR}/../board/mps2_an386.ld -Wl,--gc-sections"
    CACHE STRING "Cortex-M4 link: rdimon semihosting, board/mps2_an386.ld" FORCE)

set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
