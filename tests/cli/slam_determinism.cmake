# Renders a short street sequence, runs `portaslam run --mode deterministic` on it twice, the
# second time with 3 local-mapping threads, tracking's projection matching on the host instead
# of the backend's kernel and the pairs copied on submit instead of read in place (--input), and
# requires identical trajectory files (DESIGN.md §6:
# same input, same trajectory, byte for byte), then on every other backend available and requires
# cpu's bytes there too.
# Run as a script by run.cmake: cmake -DPORTASLAM=... -DWORK=... -P slam_determinism.cmake
if(NOT CMAKE_SCRIPT_MODE_FILE)
  return()
endif()
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
execute_process(COMMAND ${PORTASLAM} render --count 30 --out ${WORK}/seq --quiet RESULT_VARIABLE rc
                OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "render failed (${rc}): ${out}${err}")
endif()
foreach(run a b)
  set(threads 1)
  set(matching backend)
  set(input pinned)
  if(run STREQUAL "b")
    set(input copy)  # the frontend copies each pair instead of reading the System's input images
    set(threads 3)  # the parallel epipolar searches of triangulation give the same map
    set(matching host)  # the host's projection search finds the kernel's matches (DESIGN.md §3.10)
  endif()
  execute_process(COMMAND ${PORTASLAM} run --dataset kitti ${WORK}/seq --mode deterministic --out ${WORK}/${run}
                          --mapping-threads ${threads} --projection-match ${matching} --input ${input} --quiet
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "run ${run} failed (${rc}): ${out}${err}")
  endif()
  if(NOT out MATCHES "frames 30, tracked 30, lost 0")
    message(FATAL_ERROR "run ${run} did not track every frame:\n${out}${err}")
  endif()
endforeach()
foreach(f trajectory_tum.txt trajectory_kitti.txt keyframes_tum.txt)
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/a/${f} ${WORK}/b/${f} RESULT_VARIABLE differ)
  if(differ)
    message(FATAL_ERROR "deterministic mode gave different ${f} on two runs of the same input (1 and 3 mapping "
                        "threads; projection matching on the backend and on the host; pairs read in place and copied)")
  endif()
endforeach()
# Every other backend this machine can run gives the same bytes as cpu (the frontend is bit-exact,
# the back end is shared). A backend listed in PORTA_EQUIVALENCE_REQUIRE must be available.
execute_process(COMMAND ${PORTASLAM} backends OUTPUT_VARIABLE backends_out ERROR_VARIABLE unused)
set(compared "")
foreach(backend vulkan opencl cuda)
  if(NOT backends_out MATCHES "\n${backend} +yes +yes")
    if("$ENV{PORTA_EQUIVALENCE_REQUIRE}" MATCHES "${backend}")
      message(FATAL_ERROR "${backend} is required (PORTA_EQUIVALENCE_REQUIRE) but not available:\n${backends_out}")
    endif()
    continue()
  endif()
  execute_process(COMMAND ${PORTASLAM} run --dataset kitti ${WORK}/seq --mode deterministic --backend ${backend}
                          --out ${WORK}/${backend} --quiet RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "run on ${backend} failed (${rc}): ${out}${err}")
  endif()
  foreach(f trajectory_tum.txt trajectory_kitti.txt keyframes_tum.txt)
    execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/a/${f} ${WORK}/${backend}/${f} RESULT_VARIABLE differ)
    if(differ)
      message(FATAL_ERROR "deterministic mode on ${backend} gave a different ${f} than on cpu")
    endif()
  endforeach()
  list(APPEND compared ${backend})
endforeach()
file(STRINGS ${WORK}/a/trajectory_tum.txt lines)
list(LENGTH lines n)
if(n LESS 31)
  message(FATAL_ERROR "trajectory_tum.txt has ${n} lines, expected a header and 30 poses")
endif()
message(STATUS "deterministic: identical trajectory files over two runs (${n} lines); same bytes on: cpu ${compared}")
