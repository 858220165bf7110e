# ci/gpu-slam.sh, ci/gpu.sh and ci/gpu-kernel-profile.sh refuse a bad setting before they build
# anything (label cli). Each numeric setting of gpu-slam.sh, given a word, exits 2 naming the
# setting. The GPU runs themselves need a GPU machine.
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

# ci/gpu.sh's second pass (the kernels of CPU devices on the GPU's drivers) takes on or off; any
# other value is refused before anything is configured or built.
add_test(NAME cli.gpu_equivalence_refuses_PORTA_GPU_CPU_PATHS
         COMMAND ${CMAKE_COMMAND} -E env PORTA_GPU_CPU_PATHS=maybe ${PORTA_BASH} ${CMAKE_SOURCE_DIR}/ci/gpu.sh
                 ${porta_cli_dir}/gpu_equivalence_refused)
set_tests_properties(cli.gpu_equivalence_refuses_PORTA_GPU_CPU_PATHS PROPERTIES LABELS cli TIMEOUT 30
                     PASS_REGULAR_EXPRESSION "gpu.sh: PORTA_GPU_CPU_PATHS must be on or off, got 'maybe'")

# ci/gpu-kernel-profile.sh: an unknown variant, a cell it does not have, frames that are no number.
foreach(case "PORTA_PROFILE_VARIANTS=sometimes|PORTA_PROFILE_VARIANTS names 'sometimes'; known:"
             "PORTA_PROFILE_CELLS=64x64-1|PORTA_PROFILE_CELLS='64x64-1' names no cell"
             "PORTA_PROFILE_FRAMES=lots|PORTA_PROFILE_FRAMES must be a whole number of frames, got 'lots'")
  string(REPLACE "|" ";" parts "${case}")
  list(GET parts 0 assignment)
  list(GET parts 1 message)
  string(REGEX REPLACE "=.*" "" setting "${assignment}")
  add_test(NAME cli.gpu_kernel_profile_refuses_${setting}
           COMMAND ${CMAKE_COMMAND} -E env ${assignment} ${PORTA_BASH}
                   ${CMAKE_SOURCE_DIR}/ci/gpu-kernel-profile.sh ${porta_cli_dir}/gpu_kernel_profile_refused)
  set_tests_properties(cli.gpu_kernel_profile_refuses_${setting} PROPERTIES LABELS cli TIMEOUT 30
                       PASS_REGULAR_EXPRESSION "gpu-kernel-profile.sh: ${message}")
endforeach()
