# The installed package (cmake/PortaInstall.cmake), label install: `cmake --install` into a fresh
# prefix, then examples/cpp configured and built against it with find_package(PortaSLAM) and run:
# detect_features gives the keypoint and match counts `portaslam features` gives on the same pair,
# run_slam tracks every frame of a rendered sequence within 5 cm of the truth; the installed
# portaslam program renders that sequence. A component the build lacks fails find_package with a
# message naming it; run_slam on a missing folder exits 1 naming it.
# Registered when included by tests/CMakeLists.txt; the checks run as a script:
#   cmake -DBUILD=... -DSOURCE=... -DGENERATOR=... -DWORK=... -P install_package.cmake
if(NOT CMAKE_SCRIPT_MODE_FILE)
  if(TARGET porta_slam AND TARGET porta_dataset AND TARGET porta_eval AND TARGET porta_render)
    add_test(NAME install.consumer_examples
             COMMAND ${CMAKE_COMMAND} -DBUILD=${CMAKE_BINARY_DIR} -DSOURCE=${CMAKE_SOURCE_DIR}
                     "-DGENERATOR=${CMAKE_GENERATOR}" -DWORK=${porta_cli_dir}/install_package
                     -P ${CMAKE_CURRENT_LIST_FILE})
    set_tests_properties(install.consumer_examples PROPERTIES LABELS install TIMEOUT 600)
  endif()
  return()
endif()

function(run expect_rc)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL expect_rc)
    message(FATAL_ERROR "${ARGN}: exit ${rc}, expected ${expect_rc}\n${out}${err}")
  endif()
  set(out "${out}" PARENT_SCOPE)
  set(err "${err}" PARENT_SCOPE)
endfunction()

if(NOT DEFINED MAX_ATE)
  set(MAX_ATE 0.05)
endif()
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
set(prefix ${WORK}/prefix)
run(0 ${CMAKE_COMMAND} --install ${BUILD} --prefix ${prefix})
foreach(f lib/cmake/PortaSLAM/PortaSLAMConfig.cmake lib/cmake/PortaSLAM/PortaSLAMConfigVersion.cmake
          lib/cmake/PortaSLAM/PortaSLAMTargets.cmake include/porta/frontend.hpp include/porta/slam/system.hpp
          include/porta/imageio/png_file.hpp bin/portaslam)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "cmake --install did not install ${f}")
  endif()
endforeach()

# The consumer: configured and built against the prefix only.
run(0 ${CMAKE_COMMAND} -S ${SOURCE}/examples/cpp -B ${WORK}/examples -G ${GENERATOR} -DCMAKE_PREFIX_PATH=${prefix}
    -DCMAKE_BUILD_TYPE=Release)
run(0 ${CMAKE_COMMAND} --build ${WORK}/examples)

set(seq ${WORK}/seq)
run(0 ${prefix}/bin/portaslam render --path street-loop --count 20 --threads 2 --quiet --out ${seq})
set(left ${seq}/image_0/000000.png)
set(right ${seq}/image_1/000000.png)

run(0 ${BUILD}/apps/portaslam features ${left} ${right} --backend cpu)
if(NOT out MATCHES "total +([0-9]+) +([0-9]+) keypoints" )
  message(FATAL_ERROR "portaslam features printed no keypoint totals:\n${out}")
endif()
set(want_left ${CMAKE_MATCH_1})
set(want_right ${CMAKE_MATCH_2})
if(NOT out MATCHES "stereo matches: ([0-9]+) of")
  message(FATAL_ERROR "portaslam features printed no match count:\n${out}")
endif()
set(want_matches ${CMAKE_MATCH_1})
run(0 ${WORK}/examples/detect_features ${left} ${right} --backend cpu)
if(NOT out MATCHES ": ${want_left} / ${want_right} keypoints, ${want_matches} stereo matches")
  message(FATAL_ERROR "detect_features disagrees with portaslam features "
                      "(${want_left} / ${want_right} keypoints, ${want_matches} matches):\n${out}")
endif()

execute_process(COMMAND ${WORK}/examples/run_slam ${seq} WORKING_DIRECTORY ${WORK}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT out MATCHES "20 of 20 frames tracked")
  message(FATAL_ERROR "run_slam: exit ${rc}, expected every frame tracked:\n${out}${err}")
endif()
if(NOT out MATCHES "ATE RMSE ([0-9.]+) m")
  message(FATAL_ERROR "run_slam printed no ATE:\n${out}")
endif()
set(ate ${CMAKE_MATCH_1})
if(ate GREATER_EQUAL ${MAX_ATE})
  message(FATAL_ERROR "run_slam: ATE ${ate} m on 20 rendered frames (expected under ${MAX_ATE} m)")
endif()
if(NOT EXISTS ${WORK}/trajectory_tum.txt)
  message(FATAL_ERROR "run_slam wrote no trajectory_tum.txt")
endif()

# Bad input: a missing folder; a component this installation does not have.
run(1 ${WORK}/examples/run_slam ${WORK}/no_such_sequence)
if(NOT err MATCHES "no_such_sequence")
  message(FATAL_ERROR "run_slam on a missing folder does not name it:\n${err}")
endif()
file(WRITE ${WORK}/bad_component/CMakeLists.txt
     "cmake_minimum_required(VERSION 3.22)\nproject(bad LANGUAGES CXX)\n"
     "find_package(PortaSLAM REQUIRED COMPONENTS slam no_such_backend)\n")
run(1 ${CMAKE_COMMAND} -S ${WORK}/bad_component -B ${WORK}/bad_component/build -G ${GENERATOR}
    -DCMAKE_PREFIX_PATH=${prefix})
string(REGEX REPLACE "[ \n]+" " " said "${out}${err}")  # CMake wraps the message
if(NOT said MATCHES "built without 'no_such_backend'")
  message(FATAL_ERROR "find_package with a missing component does not name it:\n${out}${err}")
endif()
message(STATUS "installed package: consumer examples built and ran (${want_left} / ${want_right} keypoints, "
               "${want_matches} matches, ATE ${ate} m)")
