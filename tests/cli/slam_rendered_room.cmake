# Renders 20 frames of the built-in room flight in EuRoC layout, then runs SLAM on it through the
# EuRoC reader: every frame tracked, ground truth found, ATE under 3 cm (run.cmake).
if(NOT CMAKE_SCRIPT_MODE_FILE)
  return()
endif()
file(REMOVE_RECURSE ${WORK})
execute_process(COMMAND ${PORTASLAM} render --path room-orbit --count 20 --out ${WORK}/seq --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT out MATCHES "EuRoC layout")
  message(FATAL_ERROR "render failed (${rc}): ${out}${err}")
endif()
execute_process(COMMAND ${PORTASLAM} run --dataset euroc ${WORK}/seq --mode deterministic --out ${WORK}/run --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "run failed (${rc}): ${out}${err}")
endif()
if(NOT out MATCHES "ground truth 20 poses" OR NOT out MATCHES "frames 20, tracked 20, lost 0")
  message(FATAL_ERROR "the rendered EuRoC sequence was not read or not tracked:\n${out}${err}")
endif()
if(NOT out MATCHES "ATE \\(SE\\(3\\)-aligned, 20 poses of 20 frames\\): RMSE 0\\.0[0-2][0-9]* m")
  message(FATAL_ERROR "ATE missing or not under 3 cm:\n${out}")
endif()
message(STATUS "rendered room in EuRoC layout: read, tracked, ATE under 3 cm")
