# CLI tests of `portaslam eval` (label: cli): small trajectories with known answers written here at
# configure time, the shared real ground truths against themselves, the JSON report and plots, and
# every kind of bad input (exit status 1 and a clear message on stderr). Included by
# tests/CMakeLists.txt when the portaslam target exists; only when portaslam has `eval`.
if(NOT TARGET porta_eval)
  return()
endif()

set(porta_eval_checker ${CMAKE_CURRENT_LIST_DIR}/check_cli_output.cmake)
set(porta_eval_dir ${CMAKE_CURRENT_BINARY_DIR}/cli_eval)
file(MAKE_DIRECTORY ${porta_eval_dir})

# porta_eval_cli_test(NAME EXIT N [STDOUT regex] [STDERR regex] [FILE path] ARGS ...): runs
# `portaslam eval ARGS` in ${porta_eval_dir} and requires the exit status and the text. Its own
# function: features.cmake's porta_cli_test is defined after this file is included.
function(porta_eval_cli_test name)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "EXIT;STDOUT;STDERR;FILE" "ARGS")
  add_test(NAME cli.eval_${name}
           COMMAND ${CMAKE_COMMAND} -DEXPECT_EXIT=${arg_EXIT} "-DEXPECT_STDOUT=${arg_STDOUT}"
                   "-DEXPECT_STDERR=${arg_STDERR}" "-DEXPECT_FILE=${arg_FILE}" -P ${porta_eval_checker}
                   -- $<TARGET_FILE:portaslam> eval ${arg_ARGS}
           WORKING_DIRECTORY ${porta_eval_dir})
  set_tests_properties(cli.eval_${name} PROPERTIES LABELS cli TIMEOUT 60)
endfunction()

# ---- Inputs with known answers -------------------------------------------------------------------
# gt.tum: 10 poses at 1 s intervals on the parabola (k, k^2, 0), identity orientation.
# offsets.tum: the same with z = +0.1, -0.1, +0.1, ...: with --align none the ATE is 0.1 m at every
#              pose and every 1-frame RPE 0.2 m (an alignment would tilt the estimate a little:
#              over 10 poses the signs correlate with x).
# late.tum:    the same poses 100 s later (no pose within 0.02 s unless --time-offset -100).
# gt.kitti / short.kitti: KITTI poses of 10 and 9 lines (index association needs equal counts).
set(porta_gt "# t x y z qx qy qz qw\n")
set(porta_offsets "")
set(porta_late "")
set(porta_kitti "")
set(porta_short_kitti "")
foreach(k RANGE 9)
  math(EXPR k2 "${k} * ${k}")
  math(EXPR odd "${k} % 2")
  if(odd)
    set(z "-0.1")
  else()
    set(z "0.1")
  endif()
  math(EXPR late "${k} + 100")
  string(APPEND porta_gt "${k} ${k} ${k2} 0 0 0 0 1\n")
  string(APPEND porta_offsets "${k} ${k} ${k2} ${z} 0 0 0 1\n")
  string(APPEND porta_late "${late} ${k} ${k2} 0 0 0 0 1\n")
  string(APPEND porta_kitti "1 0 0 ${k} 0 1 0 ${k2} 0 0 1 0\n")
  if(k LESS 9)
    string(APPEND porta_short_kitti "1 0 0 ${k} 0 1 0 ${k2} 0 0 1 0\n")
  endif()
endforeach()
file(WRITE ${porta_eval_dir}/gt.tum "${porta_gt}")
file(WRITE ${porta_eval_dir}/offsets.tum "${porta_offsets}")
file(WRITE ${porta_eval_dir}/late.tum "${porta_late}")
file(WRITE ${porta_eval_dir}/gt.kitti "${porta_kitti}")
file(WRITE ${porta_eval_dir}/short.kitti "${porta_short_kitti}")
file(WRITE ${porta_eval_dir}/garbage.txt "this is not a trajectory\n")

# ---- Help ----------------------------------------------------------------------------------------
porta_eval_cli_test(help EXIT 0 STDOUT "Usage: portaslam eval GT_FILE EST_FILE.*--align A.*--rpe-distance M.*--plots DIR"
                    ARGS --help)
add_test(NAME cli.eval_help_command
         COMMAND ${CMAKE_COMMAND} -DEXPECT_EXIT=0 "-DEXPECT_STDOUT=Usage: portaslam eval GT_FILE EST_FILE"
                 -P ${porta_eval_checker} -- $<TARGET_FILE:portaslam> help eval)
set_tests_properties(cli.eval_help_command PROPERTIES LABELS cli TIMEOUT 60)

# ---- Known answers -------------------------------------------------------------------------------
porta_eval_cli_test(identity EXIT 0
                    STDOUT "association +by time.*10 of 10 estimate poses matched.*ATE +RMSE 0\\.0000 m.*RPE +over 1 frame, 9 pairs: translation RMSE 0\\.0000 m"
                    ARGS gt.tum gt.tum)
porta_eval_cli_test(offsets_align_none EXIT 0
                    STDOUT "alignment +none\n.*ATE +RMSE 0\\.1000 m, mean 0\\.1000, median 0\\.1000, std 0\\.0000, min 0\\.1000, max 0\\.1000 m.*translation RMSE 0\\.2000 m"
                    ARGS gt.tum offsets.tum --align none)
porta_eval_cli_test(time_offset EXIT 0 STDOUT "estimate offset -100 s\\): 10 of 10 estimate poses matched.*ATE +RMSE 0\\.0000 m"
                    ARGS gt.tum late.tum --time-offset -100)
porta_eval_cli_test(kitti_by_index EXIT 0
                    STDOUT "association +by index.*10 pairs.*KITTI +no KITTI segments: .*shorter than the shortest segment \\(100 m\\)"
                    ARGS gt.kitti gt.kitti)
porta_eval_cli_test(rpe_distance EXIT 0 STDOUT "RPE +over 20 m, [0-9]+ pairs" ARGS gt.tum offsets.tum --rpe-distance 20)
porta_eval_cli_test(json_report EXIT 0 FILE ${porta_eval_dir}/report.json STDOUT "wrote report\\.json"
                    ARGS gt.tum offsets.tum --json report.json)
porta_eval_cli_test(plots EXIT 0 FILE ${porta_eval_dir}/plots/trajectory.png
                    STDOUT "wrote plots/trajectory\\.png\nwrote plots/ate\\.png\nwrote plots/rpe\\.png"
                    ARGS gt.tum offsets.tum --plots plots)

# ---- Bad input -----------------------------------------------------------------------------------
porta_eval_cli_test(no_files EXIT 1 STDERR "expected GT_FILE EST_FILE, got no file")
porta_eval_cli_test(one_file EXIT 1 STDERR "expected GT_FILE EST_FILE, got only 'gt\\.tum'" ARGS gt.tum)
porta_eval_cli_test(three_files EXIT 1 STDERR "too many files" ARGS gt.tum gt.tum gt.tum)
porta_eval_cli_test(missing_file EXIT 1 STDERR "cannot open estimate file 'no_such\\.tum': no such file" ARGS gt.tum no_such.tum)
porta_eval_cli_test(directory EXIT 1 STDERR "cannot open ground truth file '\\.': it is a directory" ARGS . gt.tum)
porta_eval_cli_test(not_a_trajectory EXIT 1 STDERR "estimate: trajectory file garbage\\.txt, line 1" ARGS gt.tum garbage.txt)
porta_eval_cli_test(wrong_format EXIT 1 STDERR "ground truth: trajectory file gt\\.tum, line 2" ARGS gt.tum gt.tum --gt-format kitti)
porta_eval_cli_test(unknown_format EXIT 1 STDERR "option --est-format expects tum, kitti or euroc, got 'csv'"
                    ARGS gt.tum gt.tum --est-format csv)
porta_eval_cli_test(times_for_tum EXIT 1 STDERR "option --gt-times applies to KITTI pose files only" ARGS gt.tum gt.tum --gt-times gt.tum)
porta_eval_cli_test(no_association EXIT 1
                    STDERR "only 0 of the estimate's 10 poses could be paired.*estimate times \\[100\\.000000, 109\\.000000\\] s"
                    ARGS gt.tum late.tum)
porta_eval_cli_test(count_mismatch EXIT 1
                    STDERR "cannot associate by index.*ground truth has 10 poses and the estimate 9.*--gt-times FILE / --est-times FILE"
                    ARGS gt.kitti short.kitti)
porta_eval_cli_test(unknown_option EXIT 1 STDERR "unknown option '--frobnicate'" ARGS gt.tum gt.tum --frobnicate)
porta_eval_cli_test(bad_number EXIT 1 STDERR "option --max-time-diff expects a number, got '0\\.1s'"
                    ARGS gt.tum gt.tum --max-time-diff 0.1s)
porta_eval_cli_test(negative_tolerance EXIT 1 STDERR "option --max-time-diff expects seconds >= 0, got -1"
                    ARGS gt.tum gt.tum --max-time-diff -1)
porta_eval_cli_test(bad_rpe_delta EXIT 1 STDERR "option --rpe-delta expects a frame count >= 1, got 0" ARGS gt.tum gt.tum --rpe-delta 0)
porta_eval_cli_test(rpe_delta_and_distance EXIT 1 STDERR "exclude each other" ARGS gt.tum gt.tum --rpe-delta 2 --rpe-distance 5)
porta_eval_cli_test(bad_alignment EXIT 1 STDERR "option --align expects se3, sim3 or none, got 'affine'" ARGS gt.tum gt.tum --align affine)
porta_eval_cli_test(missing_value EXIT 1 STDERR "option --json needs a value" ARGS gt.tum gt.tum --json)
porta_eval_cli_test(flag_with_value EXIT 1 STDERR "option --kitti takes no value" ARGS gt.tum gt.tum --kitti=yes)
porta_eval_cli_test(plots_into_a_file EXIT 1 STDERR "option --plots: 'gt\\.tum' is a file, not a folder" ARGS gt.tum gt.tum --plots gt.tum)
porta_eval_cli_test(json_folder_missing EXIT 1 STDERR "option --json: cannot write 'no_such_folder/r\\.json': the folder 'no_such_folder' does not exist"
                    ARGS gt.tum gt.tum --json no_such_folder/r.json)

# ---- The shared real ground truths (skipped when ../shared/data is absent) ------------------------
set(porta_gt_dir ${PORTA_DATA_DIR}/gt-trajectories)
if(EXISTS ${porta_gt_dir}/kitti00_poses.txt AND EXISTS ${porta_gt_dir}/kitti00_times.txt)
  porta_eval_cli_test(kitti00_self EXIT 0
                      STDOUT "4541 pairs.*path length +3724\\.[0-9]+ m.*ATE +RMSE 0\\.0000 m.*KITTI +t_err 0\\.000 %, r_err 0\\.0000 deg/100m \\(0\\.000000 deg/m\\) over 3283 segments.* 800 m: t_err"
                      ARGS ${porta_gt_dir}/kitti00_poses.txt ${porta_gt_dir}/kitti00_poses.txt)
  porta_eval_cli_test(kitti00_times EXIT 0 STDOUT "times from .*by time.*4541 of 4541 estimate poses matched"
                      ARGS ${porta_gt_dir}/kitti00_poses.txt ${porta_gt_dir}/kitti00_poses.txt
                           --gt-times ${porta_gt_dir}/kitti00_times.txt --est-times ${porta_gt_dir}/kitti00_times.txt)
else()
  message(STATUS "PortaSLAM: cli.eval_kitti00_* skipped: ${porta_gt_dir}/kitti00_poses.txt not found")
endif()
if(EXISTS ${porta_gt_dir}/kitti07_times_poses.txt AND EXISTS ${porta_gt_dir}/euroc_v102_groundtruth.csv)
  porta_eval_cli_test(kitti07_self EXIT 0 STDOUT "kitti, 1101 poses.*by time.*ATE +RMSE 0\\.0000 m.*KITTI +t_err 0\\.000 %"
                      ARGS ${porta_gt_dir}/kitti07_times_poses.txt ${porta_gt_dir}/kitti07_times_poses.txt)
  porta_eval_cli_test(euroc_self EXIT 0 STDOUT "euroc, 16702 poses.*ATE +RMSE 0\\.0000 m.*KITTI +not computed"
                      ARGS ${porta_gt_dir}/euroc_v102_groundtruth.csv ${porta_gt_dir}/euroc_v102_groundtruth.csv)
  porta_eval_cli_test(euroc_against_kitti EXIT 1 STDERR "only 0 of the estimate's 1101 poses could be paired"
                      ARGS ${porta_gt_dir}/euroc_v102_groundtruth.csv ${porta_gt_dir}/kitti07_times_poses.txt)
endif()

# include() shares the includer's scope: leave nothing behind but the tests.
foreach(v porta_gt porta_offsets porta_late porta_kitti porta_short_kitti porta_gt_dir k k2 odd z late)
  unset(${v})
endforeach()
