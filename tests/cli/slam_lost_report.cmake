# A run whose last frames show nothing (a covered lens that is never uncovered) must not read as a
# success over the frames it did track: the ATE line says how many frames it covers and a WARNING
# names the frames without a pose (docs/RELIABILITY.md, "Honest results").
# Run as a script by reliability.cmake: cmake -DPORTASLAM=... -DWORK=... -P slam_lost_report.cmake
if(NOT CMAKE_SCRIPT_MODE_FILE)
  return()
endif()
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
execute_process(COMMAND ${PORTASLAM} render --count 30 --size 640x194 --out seq --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err WORKING_DIRECTORY ${WORK})
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "render failed (${rc}): ${out}${err}")
endif()
# Frames 20-29 become black (a plain PGM under the .png name: the reader goes by the content).
string(REPEAT "0 " 640 row)
string(REPEAT "${row}\n" 194 rows)
foreach(i RANGE 20 29)
  foreach(side image_0 image_1)
    file(WRITE ${WORK}/seq/${side}/0000${i}.png "P2\n640 194\n255\n${rows}")
  endforeach()
endforeach()
execute_process(COMMAND ${PORTASLAM} run --dataset kitti seq --mode deterministic --out run --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err WORKING_DIRECTORY ${WORK})
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "run failed (${rc}): ${out}${err}")
endif()
if(NOT err MATCHES "frame 20: tracking LOST")
  message(FATAL_ERROR "the loss at frame 20 was not reported:\n${err}")
endif()
if(NOT out MATCHES "ATE \\(SE\\(3\\)-aligned, 20 poses of 30 frames; 10 frames without a pose are not in it\\)")
  message(FATAL_ERROR "the ATE line does not say which frames it covers:\n${out}")
endif()
if(NOT out MATCHES "WARNING: 10 of 30 frames have no pose")
  message(FATAL_ERROR "no warning about the frames without a pose:\n${out}")
endif()
message(STATUS "lost frames: reported, counted on the ATE line, warned about")
