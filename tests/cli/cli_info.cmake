# cnerf synth writes a stream; cnerf info prints a breakdown whose total is the file size;
# a corrupt file is refused with the status name and a non-zero exit.
file(MAKE_DIRECTORY ${WORK})
execute_process(COMMAND ${CNERF} synth -o ${WORK}/tiny.cnrf --preset tiny --seed 7
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "synth failed (${rc}): ${out}${err}")
endif()
file(SIZE ${WORK}/tiny.cnrf size)
execute_process(COMMAND ${CNERF} info ${WORK}/tiny.cnrf
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "info failed (${rc}): ${err}")
endif()
string(REGEX MATCH "total +([0-9]+) bytes +\\(file: ([0-9]+) bytes\\)" m "${out}")
if(NOT m OR NOT CMAKE_MATCH_1 EQUAL size OR NOT CMAKE_MATCH_2 EQUAL size)
  message(FATAL_ERROR "info totals do not add up to the file size ${size}:\n${out}")
endif()
foreach(want "network 0 \\(coarse\\): depth 4, width 64" "network 1 \\(fine\\)" "latent payload"
        "frequency tables" "bits per parameter"
        "Cortex-M4 at 168 MHz \\(cost model, within [0-9]+%\\): [0-9.]+ s for a 100x100 view \\(orbit_000\\), [1-9][0-9]* instructions per ray"
        "Cortex-M55 at 160 MHz" "Cortex-M7 at 480 MHz" "Cortex-M33 at 160 MHz"
        "Cortex-M0\\+ at 133 MHz \\(cost model, within [0-9]+%\\): [0-9.]+ s")
  if(NOT out MATCHES "${want}")
    message(FATAL_ERROR "info output lacks '${want}':\n${out}")
  endif()
endforeach()
# --no-estimate: the same description without the cores' times.
execute_process(COMMAND ${CNERF} info --no-estimate ${WORK}/tiny.cnrf
                RESULT_VARIABLE rc OUTPUT_VARIABLE brief ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT brief MATCHES "bits per parameter" OR brief MATCHES "cost model")
  message(FATAL_ERROR "info --no-estimate (${rc}): expected the description without the "
                      "estimates: ${brief}${err}")
endif()
string(FIND "${out}" "${brief}" at)
if(NOT at EQUAL 0)
  message(FATAL_ERROR "info --no-estimate does not print what info prints before its estimates:\n${brief}")
endif()
# A truncated copy is refused with its status.
execute_process(COMMAND sh -c "head -c 100 '${WORK}/tiny.cnrf' > '${WORK}/trunc.cnrf'")
execute_process(COMMAND ${CNERF} info ${WORK}/trunc.cnrf
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "CNERF_E_TRUNCATED")
  message(FATAL_ERROR "truncated stream: expected failure with CNERF_E_TRUNCATED, got ${rc}: ${err}")
endif()
file(WRITE ${WORK}/empty.cnrf "")
execute_process(COMMAND ${CNERF} info ${WORK}/empty.cnrf
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "CNERF_E_TRUNCATED")
  message(FATAL_ERROR "empty file: expected CNERF_E_TRUNCATED, got ${rc}: ${err}")
endif()
execute_process(COMMAND ${CNERF} info ${WORK}/missing.cnrf
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "missing.cnrf: cannot open")
  message(FATAL_ERROR "missing file: expected a clear error, got ${rc}: ${err}")
endif()
