# `portaslam run`'s per-frame and per-keyframe logs (docs/USER_GUIDE.md, "Where the time goes"):
# frames.csv has a line per frame, mapping.csv a line per keyframe local mapping processed, in
# keyframe order, every field of its columns, and local mapping's steps add up within its total;
# tracking's time without the map's lock is there with --tracking-map-lock steps only.
# Run as a script by run.cmake: cmake -DPORTASLAM=... -DWORK=... -P slam_run_logs.cmake
if(NOT CMAKE_SCRIPT_MODE_FILE)
  return()
endif()
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})

foreach(args "render;--count;40;--out;seq;--quiet"
             "run;--dataset;kitti;seq;--mode;deterministic;--mapping-threads;2;--out;run;--quiet")
  execute_process(COMMAND ${PORTASLAM} ${args} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err
                  WORKING_DIRECTORY ${WORK})
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "portaslam ${args}: exit ${rc}:\n${out}${err}")
  endif()
endforeach()
if(NOT out MATCHES "frames 40, tracked 40, lost 0; keyframes ([0-9]+)")
  message(FATAL_ERROR "run: no summary line in:\n${out}")
endif()
set(keyframes ${CMAKE_MATCH_1})

file(STRINGS ${WORK}/run/frames.csv frame_lines)
list(LENGTH frame_lines n)
if(NOT n EQUAL 41)
  message(FATAL_ERROR "frames.csv: ${n} lines, expected a header and 40 frames")
endif()

file(STRINGS ${WORK}/run/mapping.csv lines)
list(POP_FRONT lines header)
set(columns "keyframe,queued,interval_ms,spread,process_ms,cull_points_ms,triangulation_ms,fusion_ms,ba_ran,ba_ms,ba_iterations,cull_keyframes_ms,total_ms,lock_wait_ms")
if(NOT header STREQUAL columns)
  message(FATAL_ERROR "mapping.csv header: '${header}', expected '${columns}'")
endif()
list(LENGTH lines processed)
# Every keyframe in the map was processed; culled ones were too.
if(processed LESS keyframes OR processed LESS 3)
  message(FATAL_ERROR "mapping.csv: ${processed} keyframes, the map has ${keyframes}")
endif()
set(ms "[0-9]+\\.[0-9][0-9][0-9]")
set(previous -1)
set(ba_iterated FALSE)
foreach(line IN LISTS lines)
  # Deterministic with two mapping threads: nothing queued behind, every keyframe on the pool.
  if(line MATCHES "^[0-9]+,0,${ms},1,${ms},${ms},${ms},${ms},1,${ms},[1-9][0-9]*,")
    set(ba_iterated TRUE)  # a local BA that ran and logged its iterations
  endif()
  if(NOT line MATCHES "^([0-9]+),0,${ms},1,(${ms}),(${ms}),(${ms}),(${ms}),[01],(${ms}),[0-9]+,(${ms}),(${ms}),(${ms})$")
    message(FATAL_ERROR "mapping.csv: bad line '${line}'")
  endif()
  if(NOT CMAKE_MATCH_1 GREATER previous)
    message(FATAL_ERROR "mapping.csv: keyframe ${CMAKE_MATCH_1} after ${previous}")
  endif()
  set(previous ${CMAKE_MATCH_1})
  # The steps' sum (microseconds, from the 3-decimal ms) is at most the total, give or take the six
  # fields' rounding.
  set(sum 0)
  foreach(i 2 3 4 5 6 7)
    string(REPLACE "." "" us "${CMAKE_MATCH_${i}}")
    math(EXPR sum "${sum} + ${us}")
  endforeach()
  string(REPLACE "." "" total "${CMAKE_MATCH_8}")
  math(EXPR total_and_rounding "${total} + 3")
  if(sum GREATER total_and_rounding)
    message(FATAL_ERROR "mapping.csv: '${line}': the steps sum to ${sum} us, more than the total ${total}")
  endif()
  # The wait for the map's lock is part of the total.
  string(REPLACE "." "" lock_wait "${CMAKE_MATCH_9}")
  if(lock_wait GREATER total)
    message(FATAL_ERROR "mapping.csv: '${line}': waited ${lock_wait} us for the lock, more than the total ${total}")
  endif()
endforeach()
if(NOT ba_iterated)
  message(FATAL_ERROR "mapping.csv: no keyframe's local BA ran with iterations logged")
endif()

# Tracking's time without the map's lock (frames.csv's unlocked_ms, the 16th field): none in the
# deterministic mode; some with --tracking-map-lock steps in the realtime mode.
list(POP_FRONT frame_lines frame_header)
if(NOT frame_header MATCHES ",map_wait_ms,unlocked_ms,relock_wait_ms,motion_ms,")
  message(FATAL_ERROR "frames.csv header: '${frame_header}'")
endif()
function(count_unlocked_frames lines out)
  set(n 0)
  foreach(line IN LISTS lines)
    string(REPLACE "," ";" fields "${line}")
    list(GET fields 15 unlocked)
    if(NOT unlocked MATCHES "^[0-9]+\\.[0-9][0-9][0-9]$")
      message(FATAL_ERROR "frames.csv: unlocked_ms '${unlocked}' in '${line}'")
    endif()
    if(NOT unlocked STREQUAL "0.000")
      math(EXPR n "${n} + 1")
    endif()
  endforeach()
  set(${out} ${n} PARENT_SCOPE)
endfunction()
count_unlocked_frames("${frame_lines}" deterministic_unlocked)
if(NOT deterministic_unlocked EQUAL 0)
  message(FATAL_ERROR "frames.csv: ${deterministic_unlocked} deterministic frames released the map's lock")
endif()
execute_process(COMMAND ${PORTASLAM} run --dataset kitti seq --tracking-map-lock steps --out steps --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err WORKING_DIRECTORY ${WORK})
if(NOT rc EQUAL 0 OR NOT out MATCHES "without map lock")
  message(FATAL_ERROR "run --tracking-map-lock steps: exit ${rc}:\n${out}${err}")
endif()
file(STRINGS ${WORK}/steps/frames.csv steps_lines)
list(POP_FRONT steps_lines)
count_unlocked_frames("${steps_lines}" steps_unlocked)
# Every frame after the first is tracked with the motion model and the local map: three windows.
if(steps_unlocked LESS 39)
  message(FATAL_ERROR
          "frames.csv with --tracking-map-lock steps: ${steps_unlocked} of 40 frames released the lock")
endif()
message(STATUS "frames.csv 40 frames; mapping.csv ${processed} keyframes (the map keeps ${keyframes}); "
               "${steps_unlocked} frames without the map's lock at times with --tracking-map-lock steps")
