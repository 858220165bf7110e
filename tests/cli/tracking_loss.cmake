# bench/tracking_loss.py (the covered-lens and kidnap copies of docs/BENCHMARKS.md), label cli:
# on a tiny rendered sequence the black copy has black frames exactly where asked and the same
# poses, the kidnap copy replays the frames asked for with times going on; bad input (a folder
# that is not a sequence, a range outside it, an existing destination; a report without --from,
# on a folder that holds no run, or from a frame outside the copy) exits 1 naming the problem.
# The report on a real run is checked by covered_lens.cmake.
# Registered when included by tests/CMakeLists.txt; the checks run as a script:
#   cmake -DPORTASLAM=... -DPYTHON=... -DSCRIPT=... -DWORK=... -P tracking_loss.cmake
if(NOT CMAKE_SCRIPT_MODE_FILE)
  if(TARGET porta_render)
    find_program(PORTA_PYTHON3 python3)
    if(PORTA_PYTHON3)
      add_test(NAME cli.tracking_loss_copies
               COMMAND ${CMAKE_COMMAND} -DPORTASLAM=$<TARGET_FILE:portaslam> -DPYTHON=${PORTA_PYTHON3}
                       -DSCRIPT=${CMAKE_SOURCE_DIR}/bench/tracking_loss.py -DWORK=${porta_cli_dir}/tracking_loss
                       -P ${CMAKE_CURRENT_LIST_FILE})
      set_tests_properties(cli.tracking_loss_copies PROPERTIES LABELS cli TIMEOUT 120)
    endif()
  endif()
  return()
endif()

function(run_script expect_rc expect_err)
  execute_process(COMMAND ${PYTHON} ${SCRIPT} ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL expect_rc)
    message(FATAL_ERROR "tracking_loss.py ${ARGN}: exit ${rc}, expected ${expect_rc}\n${out}${err}")
  endif()
  if(expect_err AND NOT err MATCHES "${expect_err}")
    message(FATAL_ERROR "tracking_loss.py ${ARGN}: stderr does not match '${expect_err}':\n${err}")
  endif()
endfunction()
function(count_lines file var)
  file(STRINGS ${file} lines)
  list(LENGTH lines n)
  set(${var} ${n} PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
execute_process(COMMAND ${PORTASLAM} render --size 96x32 --count 8 --threads 2 --quiet --out ${WORK}/seq
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "render failed (${rc}): ${out}${err}")
endif()

# Black frames 2 and 3 of both cameras; the others and the poses as they were.
run_script(0 "" black ${WORK}/seq ${WORK}/black --first 2 --count 2)
foreach(cam image_0 image_1)
  foreach(i 0 1 2 3 4 5 6 7)
    execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/seq/${cam}/00000${i}.png
                            ${WORK}/black/${cam}/00000${i}.png RESULT_VARIABLE differ)
    if((i EQUAL 2 OR i EQUAL 3) AND NOT differ)
      message(FATAL_ERROR "black copy: ${cam} frame ${i} is the original, not black")
    elseif(NOT (i EQUAL 2 OR i EQUAL 3) AND differ)
      message(FATAL_ERROR "black copy: ${cam} frame ${i} differs from the original")
    endif()
  endforeach()
endforeach()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/seq/poses.txt ${WORK}/black/poses.txt
                RESULT_VARIABLE differ)
if(differ)
  message(FATAL_ERROR "black copy: the poses changed")
endif()
# The black frame reads back as an image of the same size with no corner in it.
execute_process(COMMAND ${PORTASLAM} features ${WORK}/black/image_0/000002.png --out ${WORK}/black_features.png
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT out MATCHES "image +96x32" OR NOT out MATCHES "0 +1.000 +96x32 +0\n")
  message(FATAL_ERROR "the black frame does not read back as a 96x32 image without corners (${rc}):\n${out}${err}")
endif()

# Kidnap: frames 0..4 then 1..2 again: 7 frames, frame 5 of the copy is frame 1 of the source.
run_script(0 "" kidnap ${WORK}/seq ${WORK}/kidnap --after 4 --back 1 --count 2)
count_lines(${WORK}/kidnap/times.txt times)
count_lines(${WORK}/kidnap/poses.txt poses)
if(NOT times EQUAL 7 OR NOT poses EQUAL 7)
  message(FATAL_ERROR "kidnap copy: ${times} times and ${poses} poses, expected 7")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/seq/image_1/000001.png
                        ${WORK}/kidnap/image_1/000005.png RESULT_VARIABLE differ)
if(differ)
  message(FATAL_ERROR "kidnap copy: frame 5 is not the source's frame 1")
endif()
file(STRINGS ${WORK}/seq/poses.txt source_poses)
file(STRINGS ${WORK}/kidnap/poses.txt copy_poses)
list(GET source_poses 2 want)
list(GET copy_poses 6 got)
if(NOT want STREQUAL got)
  message(FATAL_ERROR "kidnap copy: pose 6 is not the source's pose 2")
endif()

# Bad input: each named, exit 1, nothing written.
run_script(1 "times.txt: missing" black ${WORK}/nosuch ${WORK}/out1)
run_script(1 "must lie within the 8 frames" black ${WORK}/seq ${WORK}/out2 --first 7 --count 2)
run_script(1 "need 0 <= --back < --after" kidnap ${WORK}/seq ${WORK}/out3 --after 2 --back 5)
run_script(1 "exists; give a new folder" black ${WORK}/seq ${WORK}/black --first 1 --count 1)
run_script(1 "report needs --from F" report ${WORK}/black ${WORK}/nosuch_run)
run_script(1 "trajectory_tum.txt: missing" report ${WORK}/black ${WORK}/nosuch_run --from 2)
run_script(1 "must lie within the 8 frames" report ${WORK}/black ${WORK}/seq --from 9)
foreach(d out1 out2 out3)
  if(EXISTS ${WORK}/${d} OR EXISTS ${WORK}/${d}.partial)
    message(FATAL_ERROR "a refused copy left ${WORK}/${d}")
  endif()
endforeach()
