# A pair that cannot be read partway through a sequence ends `portaslam run` with the file named
# and exit status 1, both as fast as possible (read ahead on a reader thread, into the System's
# input images or copied) and paced like a camera (read on the frames' thread); no trajectory is
# written. Run as a script by run.cmake: cmake -DPORTASLAM=... -DWORK=... -P run_truncated_image.cmake
if(NOT CMAKE_SCRIPT_MODE_FILE)
  return()
endif()
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
execute_process(COMMAND ${PORTASLAM} render --count 8 --size 320x97 --out ${WORK}/seq --quiet RESULT_VARIABLE rc
                OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "render failed (${rc}): ${out}${err}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E copy ${WORK}/seq/image_0/000004.png ${WORK}/full.png)
foreach(variant "--input;pinned" "--input;copy" "--rate;4")
  string(REPLACE ";" "-" name "${variant}")
  # A truncated file: the first 500 bytes of a valid PNG of the sequence.
  execute_process(COMMAND head -c 500 ${WORK}/full.png OUTPUT_FILE ${WORK}/seq/image_0/000005.png)
  execute_process(COMMAND ${PORTASLAM} run --dataset kitti ${WORK}/seq --out ${WORK}/${name} --quiet ${variant}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 1)
    message(FATAL_ERROR "run ${variant} on a truncated image exited ${rc}, expected 1:\n${out}${err}")
  endif()
  if(NOT err MATCHES "000005.png': corrupt or truncated PNG")
    message(FATAL_ERROR "run ${variant}: the error does not name the truncated file:\n${err}")
  endif()
  if(EXISTS ${WORK}/${name}/trajectory_tum.txt)
    message(FATAL_ERROR "run ${variant} wrote a trajectory although it failed")
  endif()
endforeach()
message(STATUS "truncated image: exit 1 naming the file with --input pinned, --input copy and --rate 4")
