# CLI tests of the reliability classes (issue 14; docs/RELIABILITY.md): every number that reaches an
# int, a size, a thread count or an allocation is bounded, with the value as the user wrote it in
# the message; nothing is written outside the folder the user named; outputs are checked before the
# work; values no real camera or trajectory has are refused instead of ending in inf, nan or a crash.
# porta_cli_test() and porta_cli_dir come from features.cmake (included before this file).

# ---- Unbounded numbers -----------------------------------------------------------------------------
porta_cli_test(features_too_many_threads EXIT 1
               STDERR "option --threads expects an integer in \\[0, 256\\], got '100000' \\(out of range\\)"
               ARGS features --threads 100000)
porta_cli_test(bench_too_many_threads EXIT 1 STDERR "option --threads expects an integer in \\[0, 256\\], got '5000'"
               ARGS bench --threads 5000)
porta_cli_test(run_too_many_threads EXIT 1 STDERR "option --threads expects an integer in \\[0, 256\\], got '99999'"
               ARGS run --dataset kitti x --threads 99999)
porta_cli_test(integer_beyond_64_bits_shown_as_written EXIT 1
               STDERR "option --levels expects an integer, got '99999999999999999999' \\(out of range\\)"
               ARGS features --levels 99999999999999999999)
porta_cli_test(integer_beyond_32_bits_shown_as_written EXIT 1
               STDERR "option --threads expects an integer in \\[0, 256\\], got '4294967297'"
               ARGS features --threads 4294967297)
porta_cli_test(run_tiny_rate EXIT 1 STDERR "option --rate expects 0 \\(as fast as possible\\) or a rate in \\[0.001, 1000\\].*got '1e-300'"
               ARGS run --dataset kitti x --rate 1e-300)
if(TARGET porta_render)
  porta_cli_test(render_too_many_threads EXIT 1 STDERR "option --threads expects an integer in \\[0, 256\\]"
                 ARGS render --threads 70000 --out rel-render)
  # fx 1e300 used to overflow an int in the rasteriser (UBSan, then SIGSEGV).
  porta_cli_test(render_huge_focal_length EXIT 1
                 STDERR "bad camera: stereo camera: fx 1e\\+300 is outside \\[248.4, 124200\\] px for a 1242x375 image"
                 ARGS render --fx 1e300 --count 1 --out rel-render)
  porta_cli_test(render_principal_point_off_the_image EXIT 1 STDERR "cx 5000 is outside the image, \\[0, 1242\\]"
                 ARGS render --cx 5000 --count 1 --out rel-render)
endif()

# ---- Writes only where the user said -----------------------------------------------------------------
# `demo --dir ''` used to write DIR/sequence as /sequence and DIR/run as the system's /run.
porta_cli_test(demo_empty_dir EXIT 1 STDERR "option --dir expects a folder, got an empty path" ARGS demo --dir=)
porta_cli_test(demo_root_dir EXIT 1 STDERR "option --dir must not name the filesystem root \\('/'\\)"
               ARGS demo --dir /)
porta_cli_test(demo_root_dir_spelled_otherwise EXIT 1 STDERR "must not name the filesystem root \\('/tmp/..'\\)"
               ARGS demo --dir /tmp/..)
porta_cli_test(run_empty_out EXIT 1 STDERR "option --out expects a folder, got an empty path"
               ARGS run --dataset kitti x --out=)
porta_cli_test(run_root_out EXIT 1 STDERR "option --out must not name the filesystem root" ARGS run --dataset kitti x --out /)
if(TARGET porta_render)
  porta_cli_test(render_root_out EXIT 1 STDERR "option --out must not name the filesystem root"
                 ARGS render --out / --count 1)
endif()

# ---- Outputs checked before the work -----------------------------------------------------------------
porta_cli_test(run_json_folder_missing EXIT 1
               STDERR "option --json: cannot write 'no/such/folder/summary.json': the folder 'no/such/folder' does not exist"
               ARGS run --dataset kitti x --json no/such/folder/summary.json)
porta_cli_test(run_save_map_folder_missing EXIT 1 STDERR "option --save-map: cannot write 'no/such/map.pmap'"
               ARGS run --dataset kitti x --save-map no/such/map.pmap)
porta_cli_test(bench_json_is_a_folder EXIT 1 STDERR "option --json: '.' is a folder, not a file" ARGS bench --json .)

# ---- Values no trajectory has: refused, not evaluated to inf --------------------------------------------
if(TARGET porta_eval)
  file(WRITE ${porta_cli_dir}/rel_gt.txt "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 1 0 0 0 0 1 0\n1 0 0 2 0 1 0 0 0 0 1 0\n")
  file(WRITE ${porta_cli_dir}/rel_huge.txt
       "1 0 0 1e300 0 1 0 0 0 0 1 0\n1 0 0 -1e300 0 1 0 0 0 0 1 1\n1 0 0 0 0 1 0 0 0 0 1 2\n")
  porta_cli_test(eval_values_near_1e300 EXIT 1 STDERR "rel_huge.txt: pose 0 has a coordinate beyond 1e\\+09 m"
                 ARGS eval rel_gt.txt rel_huge.txt)
  porta_cli_test(eval_json_checked_before_the_evaluation EXIT 1
                 STDERR "option --json: cannot write 'no/such/e.json': the folder 'no/such' does not exist"
                 ARGS eval rel_gt.txt rel_gt.txt --json no/such/e.json)
endif()

# ---- Honest results: lost frames are counted where the ATE is reported --------------------------------
if(TARGET porta_render AND TARGET porta_slam)
  add_test(NAME cli.run_lost_frames_reported_on_the_ate_line
           COMMAND ${CMAKE_COMMAND} -DPORTASLAM=$<TARGET_FILE:portaslam> -DWORK=${porta_cli_dir}/lost-report
                   -P ${CMAKE_CURRENT_LIST_DIR}/slam_lost_report.cmake)
  set_tests_properties(cli.run_lost_frames_reported_on_the_ate_line PROPERTIES LABELS cli TIMEOUT 300)
endif()
