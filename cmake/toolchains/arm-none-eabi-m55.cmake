# Cortex-M55 (Armv8.1-M Mainline with MVE, Helium) bare-metal toolchain for the AN547
# firmware: cmake/toolchains/arm-none-eabi.cmake with another CPU. -mfloat-abi=softfp keeps
# the soft-float calling convention (the decoder has no floating point) but lets GCC use the
# FPU and MVE registers, which startup.c enables (CP10/CP11).
# cmake -S . -B build-fw-an547 -DCMAKE_TOOLCHAIN_FILE=cmake/toolchains/arm-none-eabi-m55.cmake
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi.cmake)
set(_cnerf_m55_flags "-mcpu=cortex-m55 -mthumb -mfloat-abi=softfp")
foreach(_v CMAKE_C_FLAGS_INIT CMAKE_EXE_LINKER_FLAGS_INIT)
  string(REPLACE "${CNERF_CPU_FLAGS}" "${_cnerf_m55_flags}" ${_v} "${${_v}}")
endforeach()
set(CNERF_CPU_FLAGS "${_cnerf_m55_flags}")
