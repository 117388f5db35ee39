# Cortex-M0+ bare-metal toolchain for its firmware: cmake/toolchains/arm-none-eabi.cmake with
# another CPU (soft float: the decoder has no floating point).
# cmake -S . -B build-fw-m0plus -DCMAKE_TOOLCHAIN_FILE=cmake/toolchains/arm-none-eabi-m0plus.cmake
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi.cmake)
set(_cnerf_core_flags "-mcpu=cortex-m0plus -mthumb -mfloat-abi=soft")
foreach(_v CMAKE_C_FLAGS_INIT CMAKE_EXE_LINKER_FLAGS_INIT)
  string(REPLACE "${CNERF_CPU_FLAGS}" "${_cnerf_core_flags}" ${_v} "${${_v}}")
endforeach()
set(CNERF_CPU_FLAGS "${_cnerf_core_flags}")
