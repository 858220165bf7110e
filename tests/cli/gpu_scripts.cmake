# ci/gpu-slam.sh refuses a bad setting before it builds anything (label cli): each of its numeric
# settings, given a word, exits 2 naming the setting. The GPU run itself needs a GPU machine.
find_program(PORTA_BASH bash)
if(NOT PORTA_BASH)
  return()
endif()
foreach(setting PORTA_SLAM_FRAMES PORTA_SLAM_REPEATS PORTA_SLAM_RATE_FRAMES PORTA_SLAM_DETERMINISTIC PORTA_SLAM_LOOP)
  add_test(NAME cli.gpu_slam_refuses_${setting}
           COMMAND ${CMAKE_COMMAND} -E env ${setting}=x ${PORTA_BASH} ${CMAKE_SOURCE_DIR}/ci/gpu-slam.sh
                   ${porta_cli_dir}/gpu_slam_refused)
  set_tests_properties(cli.gpu_slam_refuses_${setting} PROPERTIES LABELS cli TIMEOUT 30
                       PASS_REGULAR_EXPRESSION "gpu-slam.sh: ${setting} must be a whole number, got 'x'")
endforeach()
