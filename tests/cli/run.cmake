# CLI tests of `portaslam run` and `portaslam demo` (label: cli): bad input is a clear error with
# exit status 1; the real EuRoC clip (vehicle standing still) and a rendered street are tracked
# without loss; the deterministic mode gives the same trajectory bytes twice (slam_determinism.cmake).
# porta_cli_test() and porta_cli_dir come from features.cmake (included before this file).
if(NOT TARGET porta_slam OR NOT TARGET porta_dataset)
  return()
endif()

porta_cli_test(help_run EXIT 0 STDOUT "Usage: portaslam run --dataset kitti\\|euroc\\|folder PATH.*--mode M" ARGS help run)
porta_cli_test(run_no_dataset EXIT 1 STDERR "portaslam run: no dataset given" ARGS run --mode deterministic)
porta_cli_test(run_bad_kind EXIT 1 STDERR "--dataset must be kitti, euroc or folder, got 'tum'" ARGS run --dataset tum x)
porta_cli_test(run_kind_without_path EXIT 1 STDERR "needs a PATH" ARGS run --dataset kitti)
porta_cli_test(run_missing_dataset EXIT 1 STDERR "portaslam run: .*no_such_folder" ARGS run --dataset kitti no_such_folder)
porta_cli_test(run_bad_mode EXIT 1 STDERR "--mode must be realtime or deterministic, got 'fast'"
               ARGS run --dataset kitti x --mode fast)
porta_cli_test(run_unknown_option EXIT 1 STDERR "unknown option '--speed'" ARGS run --speed 2)
porta_cli_test(run_bad_ba_every EXIT 1 STDERR "option --ba-every expects an integer in \\[0, 1000\\], got '-1'"
               ARGS run --dataset kitti x --ba-every -1)
porta_cli_test(run_bad_keyframe_gap EXIT 1 STDERR "option --keyframe-gap expects an integer in \\[0, 10\\], got '11'"
               ARGS run --dataset kitti x --keyframe-gap 11)
porta_cli_test(run_bad_ba_steps EXIT 1 STDERR "option --ba-steps expects an integer in \\[0, 100\\], got '101'"
               ARGS run --dataset kitti x --ba-steps 101)
porta_cli_test(run_ba_steps_not_a_number EXIT 1 STDERR "option --ba-steps expects an integer in \\[0, 100\\], got '1.5'"
               ARGS run --dataset kitti x --ba-steps 1.5)
porta_cli_test(run_ba_steps_without_value EXIT 1 STDERR "option --ba-steps needs a value" ARGS run --dataset kitti x --ba-steps)
porta_cli_test(run_bad_keyframe_queue EXIT 1 STDERR "option --keyframe-queue expects an integer in \\[0, 100\\], got '101'"
               ARGS run --dataset kitti x --keyframe-queue 101)
porta_cli_test(run_bad_ba_tolerance EXIT 1
               STDERR "option --ba-tolerance expects a number above 0 and below 1, got '1'"
               ARGS run --dataset kitti x --ba-tolerance 1)
porta_cli_test(run_bad_mapping_threads EXIT 1 STDERR "option --mapping-threads expects an integer in \\[0, 64\\], got '65'"
               ARGS run --dataset kitti x --mapping-threads 65)
porta_cli_test(run_bad_rate EXIT 1 STDERR "option --rate expects a number in \\[0, 1000\\], got .-1." ARGS run --dataset kitti x --rate -1)
porta_cli_test(run_rate_not_a_number EXIT 1 STDERR "option --rate expects a number, got 'abc'" ARGS run --dataset kitti x --rate abc)
porta_cli_test(run_rate_without_value EXIT 1 STDERR "option --rate needs a value" ARGS run --dataset kitti x --rate)
porta_cli_test(run_unavailable_backend EXIT 1 STDERR "portaslam run: .*(nosuch|unknown)"
               ARGS run --dataset euroc ${PORTA_DATA_DIR}/euroc-v101-head --backend nosuch)
porta_cli_test(run_missing_settings EXIT 1 STDERR "no_such_settings.yaml"
               ARGS run --dataset euroc ${PORTA_DATA_DIR}/euroc-v101-head --settings no_such_settings.yaml)
if(EXISTS ${PORTA_DATA_DIR}/kitti07-left-head)
  porta_cli_test(run_kitti_left_only EXIT 1 STDERR "no image_1 folder"
                 ARGS run --dataset kitti ${PORTA_DATA_DIR}/kitti07-left-head)
endif()
if(EXISTS ${PORTA_DATA_DIR}/euroc-v101-head)
  # Real EuRoC images, rectified by the reader; the vehicle stands still (ground truth moves <= 2.2 mm):
  # every frame tracked, and the estimate stays within 1 cm of where it started.
  porta_cli_test(run_euroc_standing_still EXIT 0
                 STDOUT "frames 24, tracked 24, lost 0.*farthest from the first pose 0\\.00[0-9]+ m.*ATE"
                 ARGS run --dataset euroc ${PORTA_DATA_DIR}/euroc-v101-head --mode deterministic --out euroc-run --quiet)
  # Paced like a camera at twice the recorded 20 Hz (0.6 s): realtime mode, every frame tracked,
  # and the report says how many frames overran their interval and which threads the CPU went to.
  porta_cli_test(run_euroc_paced EXIT 0
                 STDOUT "playback  2x the recorded frame rate.*frames 24, tracked 24, lost 0.*longer than the frame interval at 2x: [0-9]+ of 24.*host CPU by thread \\(ms per frame\\):.* porta-mapping [0-9]+\\.[0-9][0-9].*reading the images [0-9]+\\.[0-9][0-9]"
                 ARGS run --dataset euroc ${PORTA_DATA_DIR}/euroc-v101-head --rate 2 --out euroc-paced --quiet)
endif()
# The README's first command, shortened: render the street loop and track it without loss.
porta_cli_test(demo_short EXIT 0 STDOUT "rendered 40 frames.*frames 40, tracked 40, lost 0.*ATE.*tracking never lost"
               ARGS demo --render-frames 40 --mode deterministic --dir demo-short --quiet)
porta_cli_test(demo_bad_frames EXIT 1 STDERR "--render-frames must be >= 3" ARGS demo --render-frames 2)

# Deterministic mode: the same input gives the same trajectory, byte for byte.
add_test(NAME cli.run_deterministic_twice_same_bytes
         COMMAND ${CMAKE_COMMAND} -DPORTASLAM=$<TARGET_FILE:portaslam> -DWORK=${porta_cli_dir}/determinism
                 -P ${CMAKE_CURRENT_LIST_DIR}/slam_determinism.cmake)
set_tests_properties(cli.run_deterministic_twice_same_bytes PROPERTIES LABELS cli TIMEOUT 600)

# The per-frame and per-keyframe logs, frames.csv and mapping.csv (slam_run_logs.cmake).
add_test(NAME cli.run_frame_and_mapping_logs
         COMMAND ${CMAKE_COMMAND} -DPORTASLAM=$<TARGET_FILE:portaslam> -DWORK=${porta_cli_dir}/run-logs
                 -P ${CMAKE_CURRENT_LIST_DIR}/slam_run_logs.cmake)
set_tests_properties(cli.run_frame_and_mapping_logs PROPERTIES LABELS cli TIMEOUT 300)

# Rendered EuRoC layout read back by the EuRoC reader (ground truth from the rendered CSV) and tracked.
add_test(NAME cli.run_rendered_room_euroc_layout
         COMMAND ${CMAKE_COMMAND} -DPORTASLAM=$<TARGET_FILE:portaslam> -DWORK=${porta_cli_dir}/room-euroc
                 -P ${CMAKE_CURRENT_LIST_DIR}/slam_rendered_room.cmake)
set_tests_properties(cli.run_rendered_room_euroc_layout PROPERTIES LABELS cli TIMEOUT 300)

# Save, inspect, load, localise; bad map inputs refused (slam_map_session.cmake).
add_test(NAME cli.run_map_save_load_localise
         COMMAND ${CMAKE_COMMAND} -DPORTASLAM=$<TARGET_FILE:portaslam> -DWORK=${porta_cli_dir}/map-session
                 -P ${CMAKE_CURRENT_LIST_DIR}/slam_map_session.cmake)
set_tests_properties(cli.run_map_save_load_localise PROPERTIES LABELS cli TIMEOUT 600)

# New run options and map inputs: bad values are refused with the option or file named.
porta_cli_test(run_cell_zero EXIT 1 STDERR "--cell must be in \\[1, 1024\\] \\(pixels\\)" ARGS run --dataset kitti x --cell 0)
porta_cli_test(run_cell_not_a_number EXIT 1 STDERR "option --cell expects" ARGS run --dataset kitti x --cell big)
porta_cli_test(run_save_map_without_value EXIT 1 STDERR "option --save-map needs a value" ARGS run --dataset kitti x --save-map)
porta_cli_test(run_load_map_without_value EXIT 1 STDERR "option --load-map needs a value" ARGS run --dataset kitti x --load-map)
if(EXISTS ${PORTA_DATA_DIR}/euroc-v101-head)
  porta_cli_test(run_load_map_missing EXIT 1 STDERR "map file 'no_such\\.pmap': cannot open: no such file"
                 ARGS run --dataset euroc ${PORTA_DATA_DIR}/euroc-v101-head --load-map no_such.pmap --out bad-map)
  porta_cli_test(run_load_map_empty EXIT 1 STDERR "map file 'empty\\.pmap': the file is empty"
                 ARGS run --dataset euroc ${PORTA_DATA_DIR}/euroc-v101-head --load-map empty.pmap --out bad-map)
  porta_cli_test(run_save_map_is_a_folder EXIT 1 STDERR "option --save-map: '\\.' is a folder, not a file"
                 ARGS run --dataset euroc ${PORTA_DATA_DIR}/euroc-v101-head --save-map . --out bad-map)
endif()

# The place-recognition bench: usage errors exit 2, a missing dataset exits 1, each saying why.
if(TARGET porta_place_bench)
  function(porta_place_bench_test name exit pattern)
    add_test(NAME cli.${name}
             COMMAND ${CMAKE_COMMAND} -DEXPECT_EXIT=${exit} -DEXPECT_STDOUT= "-DEXPECT_STDERR=${pattern}"
                     -DEXPECT_FILE= -P ${porta_cli_checker} -- $<TARGET_FILE:porta_place_bench> ${ARGN}
             WORKING_DIRECTORY ${porta_cli_dir})
    set_tests_properties(cli.${name} PROPERTIES LABELS cli TIMEOUT 60)
  endfunction()
  porta_place_bench_test(place_bench_no_args 2 "no dataset folder given")
  porta_place_bench_test(place_bench_bad_every 2 "bad value for --every: x" x --every x)
  porta_place_bench_test(place_bench_zero_gap 2 "--every and --gap must be >= 1" x --gap 0)
  porta_place_bench_test(place_bench_missing_dataset 1 "porta_place_bench: .*no_such_folder" no_such_folder)
endif()
porta_cli_test(run_bad_projection_match EXIT 1 STDERR "--projection-match takes backend or host, got 'gpu'"
               ARGS run --dataset kitti x --projection-match gpu)
porta_cli_test(run_bad_input EXIT 1 STDERR "--input takes pinned or copy, got 'gpu'"
               ARGS run --dataset kitti x --input gpu)
porta_cli_test(run_bad_keyframes_while_mapping EXIT 1
               STDERR "--keyframes-while-mapping takes on or off, got 'maybe'"
               ARGS run --dataset kitti x --keyframes-while-mapping maybe)
porta_cli_test(run_bad_queued_follow_ba EXIT 1 STDERR "--queued-follow-ba takes on or off, got 'yes'"
               ARGS run --dataset kitti x --queued-follow-ba yes)
porta_cli_test(run_queued_follow_ba_without_value EXIT 1 STDERR "--queued-follow-ba"
               ARGS run --dataset kitti x --queued-follow-ba)
porta_cli_test(run_bad_tracking_map_lock EXIT 1
               STDERR "--tracking-map-lock takes frame or steps, got 'step'"
               ARGS run --dataset kitti x --tracking-map-lock step)

# A truncated image partway through: exit 1 naming it, no trajectory (the reader's three paths).
add_test(NAME cli.run_truncated_image_midway
         COMMAND ${CMAKE_COMMAND} -DPORTASLAM=$<TARGET_FILE:portaslam> -DWORK=${porta_cli_dir}/truncated-midway
                 -P ${CMAKE_CURRENT_LIST_DIR}/run_truncated_image.cmake)
set_tests_properties(cli.run_truncated_image_midway PROPERTIES LABELS cli TIMEOUT 300)
