# CLI tests of `portaslam render` (label: cli): tiny runs in both layouts, a real trajectory when
# the shared data is present, and every kind of bad input rejected with a clear message on stderr
# and exit status 1. porta_cli_test() and porta_cli_dir come from features.cmake (included before
# this file). Each run renders a few frames of a few dozen pixels: well under a second of work.
if(NOT TARGET porta_render)
  return()
endif()

set(porta_render_tiny --size 96x32 --count 2 --threads 2 --quiet)
file(WRITE ${porta_cli_dir}/render_empty.txt "")
file(WRITE ${porta_cli_dir}/render_corrupt.txt "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 zero 0 1 0 0 0 0 1 0\n")
file(WRITE ${porta_cli_dir}/render_two_poses.txt "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 1\n")

# ---- Help ----------------------------------------------------------------------------------------
porta_cli_test(help_render EXIT 0 STDOUT "Usage: portaslam render.*--path NAME.*--supersample K" ARGS help render)
porta_cli_test(render_help EXIT 0 STDOUT "Usage: portaslam render.*--layout L" ARGS render --help)

# ---- Runs that succeed ---------------------------------------------------------------------------
porta_cli_test(render_default_kitti EXIT 0 STDOUT "street-loop.*KITTI layout.*rendered 2 stereo frames"
               FILE render_kitti/image_1/000001.png ARGS render --out render_kitti ${porta_render_tiny})
porta_cli_test(render_room_euroc EXIT 0 STDOUT "room world.*EuRoC layout.*rendered 2 stereo frames"
               FILE render_euroc/mav0/state_groundtruth_estimate0/data.csv
               ARGS render --path room-orbit --out render_euroc ${porta_render_tiny} --noise 2 --exposure 0.2
                    --motion-blur 0.5 --blur-samples 2)
porta_cli_test(render_kitti_poses_as_room EXIT 0 STDOUT "render_two_poses.txt \\(kitti, camera poses\\).*room world"
               FILE render_two/mav0/cam0/data.csv ARGS render render_two_poses.txt --out render_two ${porta_render_tiny})
if(EXISTS ${PORTA_DATA_DIR}/gt-trajectories/kitti07_times_poses.txt)
  porta_cli_test(render_kitti07 EXIT 0 STDOUT "kitti07_times_poses.txt \\(kitti, camera poses\\).*street world.*frames: +2 \\(from 500"
                 FILE render_k07/poses.txt
                 ARGS render ${PORTA_DATA_DIR}/gt-trajectories/kitti07_times_poses.txt --first 500 --stride 2
                      --out render_k07 ${porta_render_tiny})
endif()

# ---- Bad input -----------------------------------------------------------------------------------
porta_cli_test(render_no_out EXIT 1 STDERR "option --out DIR is required" ARGS render --count 1)
porta_cli_test(render_unknown_option EXIT 1 STDERR "unknown option '--colour'" ARGS render --out x --colour)
porta_cli_test(render_bad_world EXIT 1 STDERR "--world expects street, room or auto, got 'moon'"
               ARGS render --out x --world moon)
porta_cli_test(render_bad_path EXIT 1 STDERR "--path expects street-loop or room-orbit" ARGS render --out x --path loop)
porta_cli_test(render_bad_size EXIT 1 STDERR "--size expects a size in \\[16, 8192\\]" ARGS render --out x --size 8x8)
porta_cli_test(render_bad_size_text EXIT 1 STDERR "--size expects WIDTHxHEIGHT" ARGS render --out x --size big)
porta_cli_test(render_bad_fx EXIT 1 STDERR "option --fx expects a number, got 'abc'" ARGS render --out x --fx abc)
porta_cli_test(render_bad_baseline EXIT 1 STDERR "bad camera: .*baseline" ARGS render --out x --baseline 0 --count 1)
porta_cli_test(render_bad_principal_point EXIT 1 STDERR "cx -5 is outside the image, \\[0, 1242\\]" ARGS render --out x --cx -5 --count 1)
porta_cli_test(render_bad_supersample EXIT 1 STDERR "supersample must be in \\[1, 4\\]" ARGS render --out x --supersample 0)
porta_cli_test(render_bad_noise EXIT 1 STDERR "noise sigma must be in \\[0, 64\\]" ARGS render --out x --noise -1)
porta_cli_test(render_first_outside EXIT 1 STDERR "first frame 5000 is outside the trajectory: it has [0-9]+ frames"
               ARGS render --out x --first 5000)
porta_cli_test(render_count_outside EXIT 1 STDERR "frame range \\[1, 3\\) is outside the trajectory: it has 2 frames"
               ARGS render render_two_poses.txt --out x --first 1 --count 2)
porta_cli_test(render_missing_trajectory EXIT 1 STDERR "bad trajectory: .*no_such_poses.txt"
               ARGS render no_such_poses.txt --out x)
porta_cli_test(render_empty_trajectory EXIT 1 STDERR "render_empty.txt" ARGS render render_empty.txt --out x)
porta_cli_test(render_corrupt_trajectory EXIT 1 STDERR "bad trajectory: .*render_corrupt.txt.*2"
               ARGS render render_corrupt.txt --format kitti --out x)
porta_cli_test(render_two_sources EXIT 1 STDERR "either a trajectory file or a built-in path"
               ARGS render render_two_poses.txt --path street-loop --out x)
porta_cli_test(render_out_not_writable EXIT 1 STDERR "cannot create output folder /proc/porta_render"
               ARGS render --out /proc/porta_render ${porta_render_tiny})
