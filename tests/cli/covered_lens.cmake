# Issue 13's covered-lens target, end to end (label scenario: the main test run only, ~2 minutes on
# 2 cores; too slow for the sanitizer and qemu runs): the built-in street loop at KITTI's 1242x375,
# frames 200-229 of both cameras black (bench/tracking_loss.py black), run in deterministic mode.
# Tracking is reported lost on the first black frame and stays lost while the car drives on into
# unmapped streets; when the loop brings it back to at most 15 m behind its start, looking its way,
# it relocalises within 5 frames, at most 5 cm from the truth there and on every frame after it
# (bench/tracking_loss.py report; docs/BENCHMARKS.md has the figures).
# Registered when included by tests/CMakeLists.txt; the checks run as a script:
#   cmake -DPORTASLAM=... -DPYTHON=... -DSCRIPT=... -DWORK=... -P covered_lens.cmake
if(NOT CMAKE_SCRIPT_MODE_FILE)
  if(TARGET porta_render AND TARGET porta_slam)
    find_program(PORTA_PYTHON3 python3)
    if(PORTA_PYTHON3)
      add_test(NAME scenario.covered_lens_relocalises_within_5_cm
               COMMAND ${CMAKE_COMMAND} -DPORTASLAM=$<TARGET_FILE:portaslam> -DPYTHON=${PORTA_PYTHON3}
                       -DSCRIPT=${CMAKE_SOURCE_DIR}/bench/tracking_loss.py -DWORK=${CMAKE_CURRENT_BINARY_DIR}/scenario/covered_lens
                       -P ${CMAKE_CURRENT_LIST_FILE})
      set_tests_properties(scenario.covered_lens_relocalises_within_5_cm PROPERTIES LABELS scenario TIMEOUT 900)
    endif()
  endif()
  return()
endif()

function(step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (exit ${rc}):\n${out}${err}")
  endif()
  set(step_out "${out}" PARENT_SCOPE)
endfunction()

if(NOT IS_ABSOLUTE "${WORK}" OR WORK STREQUAL "/")
  message(FATAL_ERROR "WORK must be an absolute folder of its own, got '${WORK}'")
endif()
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
step("render" ${PORTASLAM} render --path street-loop --quiet --out ${WORK}/street)
step("the black copy" ${PYTHON} ${SCRIPT} black ${WORK}/street ${WORK}/black --first 200 --count 30)
step("run" ${PORTASLAM} run --dataset kitti ${WORK}/black --mode deterministic --quiet --out ${WORK}/run)
file(READ ${WORK}/run/summary.json summary)
string(JSON lost GET "${summary}" lost)
if(lost LESS 30)
  message(FATAL_ERROR "${lost} frames reported lost; the 30 black ones at least should be")
endif()
step("the report" ${PYTHON} ${SCRIPT} report ${WORK}/black ${WORK}/run --from 200 --within 5 --max-error 0.05
     --max-error-after 0.05)
message(STATUS "${step_out}")
if(NOT step_out MATCHES "relocalised at frame")
  message(FATAL_ERROR "the report names no relocalisation:\n${step_out}")
endif()
file(REMOVE_RECURSE ${WORK})
