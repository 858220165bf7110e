# ci/gpu-slam.sh, ci/gpu-slam-variants.sh, ci/gpu.sh and ci/gpu-kernel-profile.sh refuse a bad setting before they build
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

# ci/gpu-kernel-profile.sh: an unknown variant, a cell it does not have, frames that are no number,
# too many repeats.
foreach(case "PORTA_PROFILE_VARIANTS=sometimes|PORTA_PROFILE_VARIANTS names 'sometimes'; known:"
             "PORTA_PROFILE_CELLS=64x64-1|PORTA_PROFILE_CELLS='64x64-1' names no cell"
             "PORTA_PROFILE_FRAMES=lots|PORTA_PROFILE_FRAMES must be a whole number of frames, got 'lots'"
             "PORTA_PROFILE_REPEATS=21|PORTA_PROFILE_REPEATS must be a number of runs from 1 to 20, got '21'")
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

# ci/gpu-slam-variants.sh: rounds that are no number, no variant, a variant whose script is missing,
# a setting that is not VAR=VALUE; bench/slam_variants.py on a folder without runs and on a
# truncated run summary.
foreach(case "rounds|PORTA_SLAM_ROUNDS=x|PORTA_SLAM_VARIANTS=a=ci/gpu-slam.sh|ROUNDS must be a whole number from 1 to 99, got 'x'"
             "no_variant|PORTA_SLAM_ROUNDS=2|PORTA_SLAM_VARIANTS=|no variants"
             "missing_script|PORTA_SLAM_ROUNDS=2|PORTA_SLAM_VARIANTS=a=no/such.sh|bad variant 'a=no/such.sh'"
             "setting|PORTA_SLAM_ROUNDS=2|PORTA_SLAM_VARIANTS=a=ci/gpu-slam.sh:FOO|bad variant 'a=ci/gpu-slam.sh:FOO': setting 'FOO' is not VAR=VALUE")
  string(REPLACE "|" ";" parts "${case}")
  list(GET parts 0 id)
  list(GET parts 1 rounds)
  list(GET parts 2 variants)
  list(GET parts 3 message)
  add_test(NAME cli.gpu_slam_variants_refuses_${id}
           COMMAND ${CMAKE_COMMAND} -E env ${rounds} ${variants} ${PORTA_BASH}
                   ${CMAKE_SOURCE_DIR}/ci/gpu-slam-variants.sh ${porta_cli_dir}/gpu_slam_variants_refused)
  set_tests_properties(cli.gpu_slam_variants_refuses_${id} PROPERTIES LABELS cli TIMEOUT 30
                       PASS_REGULAR_EXPRESSION "gpu-slam-variants.sh: ${message}")
endforeach()
# Variants listed with ';' (settings may then hold spaces): the list is split there and each
# variant trimmed; the first one's missing script is named with its setting, spaces and all.
add_test(NAME cli.gpu_slam_variants_refuses_in_a_semicolon_list
         COMMAND ${CMAKE_COMMAND} -E env PORTA_SLAM_ROUNDS=1
                 "PORTA_SLAM_VARIANTS= a=no/such.sh:PORTA_SLAM_RUN_ARGS=--keyframe-gap 3 $<SEMICOLON> b=ci/gpu-slam.sh"
                 ${PORTA_BASH} ${CMAKE_SOURCE_DIR}/ci/gpu-slam-variants.sh ${porta_cli_dir}/gpu_slam_variants_refused)
set_tests_properties(cli.gpu_slam_variants_refuses_in_a_semicolon_list PROPERTIES LABELS cli TIMEOUT 30
                     PASS_REGULAR_EXPRESSION
                     "gpu-slam-variants.sh: bad variant 'a=no/such.sh:PORTA_SLAM_RUN_ARGS=--keyframe-gap 3': expected")
find_package(Python3 COMPONENTS Interpreter QUIET)
if(Python3_Interpreter_FOUND)
  file(MAKE_DIRECTORY ${porta_cli_dir}/slam_variants_empty)
  add_test(NAME cli.slam_variants_summary_without_runs
           COMMAND ${Python3_EXECUTABLE} ${CMAKE_SOURCE_DIR}/bench/slam_variants.py ${porta_cli_dir}/slam_variants_empty)
  file(MAKE_DIRECTORY ${porta_cli_dir}/slam_variants_truncated/a-1)
  file(WRITE ${porta_cli_dir}/slam_variants_truncated/a-1/fast-cuda-1.json "{\"stages_ms\": {")
  add_test(NAME cli.slam_variants_summary_truncated_json
           COMMAND ${Python3_EXECUTABLE} ${CMAKE_SOURCE_DIR}/bench/slam_variants.py ${porta_cli_dir}/slam_variants_truncated)
  set_tests_properties(cli.slam_variants_summary_truncated_json PROPERTIES LABELS cli TIMEOUT 30
                       PASS_REGULAR_EXPRESSION "fast-cuda-1\\.json: not a portaslam run summary \\(JSONDecodeError")
  set_tests_properties(cli.slam_variants_summary_without_runs PROPERTIES LABELS cli TIMEOUT 30
                       PASS_REGULAR_EXPRESSION "no runs \\(NAME-ROUND/fast-\\*-1\\.json\\) in ")
  # bench/backend_table.py (issue 16's table in ci/gpu-kernel-profile.sh's report) on hand-made runs.
  add_test(NAME cli.backend_table COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_LIST_DIR}/backend_table_test.py)
  set_tests_properties(cli.backend_table PROPERTIES LABELS cli TIMEOUT 60)
endif()
