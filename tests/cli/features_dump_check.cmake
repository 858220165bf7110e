# `portaslam features --dump` (what ci/cross-aarch64.sh compares between x86-64 and aarch64):
#  - the built-in stereo pair on 1 and on 2 worker threads gives the same file, byte for byte;
#  - the file has the documented layout (apps/portaslam/features_dump.hpp), one line per keypoint
#    with a 64-hex-digit descriptor and one per left keypoint's match, and its counts agree with
#    what the command prints;
#  - a single image gives only the left section.
# Run as a script by features.cmake: cmake -DPORTASLAM=... -DWORK=... -DSINGLE_IMAGE=... -P features_dump_check.cmake
if(NOT CMAKE_SCRIPT_MODE_FILE)
  return()
endif()
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})

foreach(threads 1 2)
  execute_process(COMMAND ${PORTASLAM} features --threads ${threads} --dump ${WORK}/t${threads}.txt
                          --out ${WORK}/t${threads}.png
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out${threads} ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "features --threads ${threads} --dump failed (${rc}): ${out${threads}}${err}")
  endif()
  if(NOT out${threads} MATCHES "wrote [^\n]*t${threads}\\.txt: every keypoint, descriptor and stereo match")
    message(FATAL_ERROR "features --dump did not say that it wrote the dump:\n${out${threads}}")
  endif()
endforeach()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/t1.txt ${WORK}/t2.txt RESULT_VARIABLE differ)
if(differ)
  message(FATAL_ERROR "features --dump on 1 and on 2 threads differ: ${WORK}/t1.txt ${WORK}/t2.txt")
endif()

# Layout and counts.
file(STRINGS ${WORK}/t1.txt lines)
list(GET lines 0 header)
list(GET lines 1 image)
if(NOT header STREQUAL "portaslam-features-dump 1" OR NOT image STREQUAL "image 640x480 stereo")
  message(FATAL_ERROR "unexpected dump header: '${header}' / '${image}'")
endif()
if(NOT out1 MATCHES "total +([0-9]+) +([0-9]+) keypoints")
  message(FATAL_ERROR "no keypoint totals in the output:\n${out1}")
endif()
set(printed_left ${CMAKE_MATCH_1})
set(printed_right ${CMAKE_MATCH_2})
if(NOT out1 MATCHES "stereo matches: ([0-9]+) of")
  message(FATAL_ERROR "no match count in the output:\n${out1}")
endif()
set(printed_matches ${CMAKE_MATCH_1})
set(expected_sections "left keypoints ${printed_left}" "right keypoints ${printed_right}"
                      "matches ${printed_matches} of ${printed_left}")
set(sections "")
set(counts_L 0)
set(counts_R 0)
set(counts_M 0)
set(matched 0)
set(hex "[0-9a-f][0-9a-f][0-9a-f][0-9a-f][0-9a-f][0-9a-f][0-9a-f][0-9a-f]")
foreach(line IN LISTS lines)
  if(line MATCHES "^(left keypoints|right keypoints|matches) ")
    list(APPEND sections "${line}")
  elseif(line MATCHES "^([LR]) ([0-9]+) [0-9]+ [0-9]+ [0-9]+ [0-9]+ [0-9]+ ${hex}${hex}${hex}${hex}${hex}${hex}${hex}${hex}$")
    if(NOT CMAKE_MATCH_2 EQUAL counts_${CMAKE_MATCH_1})
      message(FATAL_ERROR "dump line '${line}': index ${CMAKE_MATCH_2}, expected ${counts_${CMAKE_MATCH_1}}")
    endif()
    math(EXPR counts_${CMAKE_MATCH_1} "${counts_${CMAKE_MATCH_1}} + 1")
  elseif(line MATCHES "^M ([0-9]+) (-?[0-9]+) (-?[0-9]+)$")
    if(NOT CMAKE_MATCH_1 EQUAL counts_M)
      message(FATAL_ERROR "dump line '${line}': index ${CMAKE_MATCH_1}, expected ${counts_M}")
    endif()
    math(EXPR counts_M "${counts_M} + 1")
    if(NOT CMAKE_MATCH_2 EQUAL -1)
      math(EXPR matched "${matched} + 1")
    endif()
  elseif(NOT line STREQUAL header AND NOT line STREQUAL image)
    message(FATAL_ERROR "unexpected dump line: '${line}'")
  endif()
endforeach()
if(NOT sections STREQUAL expected_sections)
  message(FATAL_ERROR "dump sections '${sections}', expected '${expected_sections}' (from the printed counts)")
endif()
if(NOT counts_L EQUAL printed_left OR NOT counts_R EQUAL printed_right OR NOT counts_M EQUAL printed_left
   OR NOT matched EQUAL printed_matches OR printed_matches EQUAL 0)
  message(FATAL_ERROR "dump has ${counts_L} left, ${counts_R} right keypoint lines, ${counts_M} match lines "
                      "(${matched} matched); the command printed ${printed_left}, ${printed_right}, ${printed_matches}")
endif()

# A single image: the left section only.
execute_process(COMMAND ${PORTASLAM} features ${SINGLE_IMAGE} --levels 2 --dump ${WORK}/single.txt
                        --out ${WORK}/single.png RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "features on one image with --dump failed (${rc}): ${out}${err}")
endif()
file(STRINGS ${WORK}/single.txt single)
list(GET single 1 single_image)
list(GET single 2 single_left)
if(NOT single_image STREQUAL "image 96x96 single" OR NOT single_left MATCHES "^left keypoints [1-9]"
   OR single MATCHES "right keypoints|matches")
  message(FATAL_ERROR "unexpected single-image dump:\n${single}")
endif()
message(STATUS "features --dump: same bytes on 1 and 2 threads; ${printed_left} + ${printed_right} keypoints, "
               "${printed_matches} matches, layout as documented")
