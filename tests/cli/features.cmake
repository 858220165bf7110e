# CLI tests of `portaslam` (label: cli): the built-in default run, the backends table, help and
# usage, and every kind of bad input the features command must reject with a clear message on
# stderr and exit status 1. Included by tests/CMakeLists.txt when the portaslam target exists.

set(porta_cli_checker ${CMAKE_CURRENT_LIST_DIR}/check_cli_output.cmake)
set(porta_cli_dir ${CMAKE_CURRENT_BINARY_DIR}/cli)
file(MAKE_DIRECTORY ${porta_cli_dir})

# porta_cli_test(NAME EXIT N [STDOUT regex] [STDERR regex] [FILE path] ARGS ...): runs
# `portaslam ARGS` in ${porta_cli_dir} and requires the exit status and the text (see the checker).
function(porta_cli_test name)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "EXIT;STDOUT;STDERR;FILE" "ARGS")
  add_test(NAME cli.${name}
           COMMAND ${CMAKE_COMMAND} -DEXPECT_EXIT=${arg_EXIT} "-DEXPECT_STDOUT=${arg_STDOUT}"
                   "-DEXPECT_STDERR=${arg_STDERR}" "-DEXPECT_FILE=${arg_FILE}" -P ${porta_cli_checker}
                   -- $<TARGET_FILE:portaslam> ${arg_ARGS}
           WORKING_DIRECTORY ${porta_cli_dir})
  set_tests_properties(cli.${name} PROPERTIES LABELS cli TIMEOUT 300)
endfunction()

# ---- Input files made at configure time (PGM/PPM are plain text, so file(WRITE) can make them). ----
file(WRITE ${porta_cli_dir}/not_an_image.png "This is a text file, not a PNG.\n")
file(WRITE ${porta_cli_dir}/empty.png "")
string(REPEAT "0 0 0 0 255 255 255 255 " 8 porta_row64)
string(REPEAT "${porta_row64}\n" 48 porta_rows)
file(WRITE ${porta_cli_dir}/gray_64x48.pgm "P2\n64 48\n255\n${porta_rows}")
string(REPEAT "0 0 0 0 255 255 255 255 " 10 porta_row80)
string(REPEAT "${porta_row80}\n" 48 porta_rows)
file(WRITE ${porta_cli_dir}/gray_80x48.pgm "P2\n80 48\n255\n${porta_rows}")
string(REPEAT "7 " 16385 porta_row)
file(WRITE ${porta_cli_dir}/too_wide_16385x1.pgm "P2\n16385 1\n255\n${porta_row}\n")
# A 96x96 colour image: 12-px squares of red, blue, yellow and green, so that it has corners.
set(porta_ppm "P3\n96 96\n255\n")
foreach(y RANGE 95)
  math(EXPR band "(${y} / 12) % 2")
  if(band)
    set(porta_square_a "255 0 0 ")
    set(porta_square_b "0 0 255 ")
  else()
    set(porta_square_a "255 255 0 ")
    set(porta_square_b "0 160 0 ")
  endif()
  string(REPEAT "${porta_square_a}" 12 porta_a)
  string(REPEAT "${porta_square_b}" 12 porta_b)
  string(REPEAT "${porta_a}${porta_b}" 4 porta_line)
  string(APPEND porta_ppm "${porta_line}\n")
endforeach()
file(WRITE ${porta_cli_dir}/colour_96x96.ppm "${porta_ppm}")

# ---- Help and dispatch ---------------------------------------------------------------------------
porta_cli_test(help EXIT 0 STDOUT "Usage: portaslam COMMAND.*backends.*features" ARGS --help)
porta_cli_test(help_command EXIT 0 STDOUT "Usage: portaslam COMMAND" ARGS help)
porta_cli_test(help_features EXIT 0 STDOUT "Usage: portaslam features.*--levels N.*\\[1, 12\\]" ARGS help features)
porta_cli_test(features_help EXIT 0 STDOUT "Usage: portaslam features.*--max-disparity D" ARGS features --help)
porta_cli_test(no_command EXIT 2 STDERR "no command given.*Usage: portaslam")
porta_cli_test(unknown_command EXIT 2 STDERR "unknown command 'frobnicate'.*Usage: portaslam" ARGS frobnicate)

# ---- backends ------------------------------------------------------------------------------------
porta_cli_test(backends EXIT 0 STDOUT "backend +built +available +detail\ncpu +yes +yes .*cuda +(yes|no).*vulkan.*opencl"
               ARGS backends)
porta_cli_test(backends_extra_argument EXIT 1 STDERR "unexpected argument 'cpu'" ARGS backends cpu)

# ---- features: runs that succeed -----------------------------------------------------------------
# The exact command a new user types: the built-in pair, default output features.png here. Most
# matches must have the pair's known disparity.
porta_cli_test(features_builtin_default EXIT 0 FILE ${porta_cli_dir}/features.png
               STDOUT "built-in synthetic stereo pair.*backend +cpu.*640x480, stereo pair.*total +[1-9][0-9]* +[1-9][0-9]* keypoints.*stereo matches: [1-9][0-9]* of [1-9][0-9]* left keypoints.*known disparity within 1 px: [0-9]+ of [0-9]+ matches \\((9[0-9]|100)\\.[0-9]%\\).*stage times.*describe.*stereo.*total.*wrote features.png"
               ARGS features)
porta_cli_test(features_builtin_repeat EXIT 0 FILE ${porta_cli_dir}/repeat.png
               STDOUT "cpu \\(1 threads?\\).*median of 3 runs after 1 warm-up run"
               ARGS features --repeat 3 --threads 1 --levels 4 --out repeat.png)
porta_cli_test(features_colour_image EXIT 0 FILE ${porta_cli_dir}/colour.png
               STDOUT "converted: 3-channel color to gray.*96x96, single image.*total +[0-9]+ keypoints"
               ARGS features colour_96x96.ppm --levels 2 --out colour.png)
porta_cli_test(features_settings_echoed EXIT 0
               STDOUT "levels 3, scale 1.5, threshold 30, arc \\[10, 16\\], edge 21, cell 16x16, pfa off, orientation bins 16\n *disparity \\[2, 64\\] px, max hamming 60"
               ARGS features --levels 3 --scale 1.5 --threshold=30 --min-arc 10 --max-arc 16 --edge 21 --cell 16
                    --no-pfa --orientation-bins 16 --min-disparity 2 --max-disparity 64 --max-hamming 60
                    --out settings.png)
porta_cli_test(features_pfa_window_even EXIT 1
               STDERR "invalid setting pfa_window = 4: allowed odd values in \\[1, 15\\] \\(set by --pfa-window\\)"
               ARGS features --pfa-window 4)
porta_cli_test(features_min_disparity_not_below_max EXIT 1
               STDERR "stereo_min_disparity = 64: allowed \\[0, 63\\] \\(set by --min-disparity\\)"
               ARGS features --min-disparity 64 --max-disparity 64)

# ---- features: bad files -------------------------------------------------------------------------
porta_cli_test(features_missing_file EXIT 1 STDERR "cannot open image 'no_such_image\\.png': no such file"
               ARGS features no_such_image.png)
porta_cli_test(features_missing_right_file EXIT 1 STDERR "cannot open image 'no_such_right\\.png': no such file"
               ARGS features gray_64x48.pgm no_such_right.png)
porta_cli_test(features_not_an_image EXIT 1 STDERR "cannot decode image 'not_an_image\\.png': not an image file"
               ARGS features not_an_image.png)
porta_cli_test(features_empty_file EXIT 1 STDERR "cannot decode image 'empty\\.png'" ARGS features empty.png)
porta_cli_test(features_directory EXIT 1 STDERR "cannot open image '\\.': it is a directory" ARGS features .)
porta_cli_test(features_size_mismatch EXIT 1
               STDERR "left and right images differ in size: 'gray_64x48\\.pgm' is 64x48, 'gray_80x48\\.pgm' is 80x48"
               ARGS features gray_64x48.pgm gray_80x48.pgm)
porta_cli_test(features_image_too_large EXIT 1
               STDERR "image 'too_wide_16385x1\\.pgm' is 16385x1: larger than the engine's limit of 16384 px"
               ARGS features too_wide_16385x1.pgm)
porta_cli_test(features_too_many_images EXIT 1 STDERR "too many images" ARGS features a.png b.png c.png)
porta_cli_test(features_bad_output_extension EXIT 1 STDERR "cannot write 'out\\.txt': no image writer"
               ARGS features --out out.txt)
porta_cli_test(features_output_folder_missing EXIT 1 STDERR "folder 'no_such_folder' does not exist"
               ARGS features --out no_such_folder/out.png)
porta_cli_test(features_dump_empty_name EXIT 1 STDERR "option --dump needs a file name"
               ARGS features --dump= --out dump_empty.png)
porta_cli_test(features_dump_folder_missing EXIT 1 STDERR "--dump.*folder 'no_such_folder' does not exist"
               ARGS features --dump no_such_folder/dump.txt --out dump_missing.png)

# ---- features --dump: the text ci/cross-aarch64.sh compares across CPUs (features_dump_check.cmake)
add_test(NAME cli.features_dump_same_bytes_any_thread_count
         COMMAND ${CMAKE_COMMAND} -DPORTASLAM=$<TARGET_FILE:portaslam> -DWORK=${porta_cli_dir}/dump
                 -DSINGLE_IMAGE=${porta_cli_dir}/colour_96x96.ppm -P ${CMAKE_CURRENT_LIST_DIR}/features_dump_check.cmake)
set_tests_properties(cli.features_dump_same_bytes_any_thread_count PROPERTIES LABELS cli TIMEOUT 300)

# ---- features: bad settings (the engine's validate() names the field and its range) -------------
porta_cli_test(features_levels_out_of_range EXIT 1
               STDERR "invalid setting levels = 13: allowed \\[1, 12\\] \\(set by --levels\\)" ARGS features --levels 13)
porta_cli_test(features_scale_out_of_range EXIT 1
               STDERR "invalid setting scale_factor = 2.5: allowed \\(1, 2\\] \\(set by --scale\\)" ARGS features --scale 2.5)
porta_cli_test(features_threshold_out_of_range EXIT 1
               STDERR "fast_threshold = 0: allowed \\[1, 254\\] \\(set by --threshold\\)" ARGS features --threshold 0)
porta_cli_test(features_max_arc_below_min_arc EXIT 1
               STDERR "max_arc = 10: allowed \\[12, 16\\] \\(set by --max-arc\\)" ARGS features --min-arc 12 --max-arc 10)
porta_cli_test(features_cell_out_of_range EXIT 1 STDERR "cell_width = 0: allowed \\[1, 1024\\] \\(set by --cell\\)"
               ARGS features --cell 0)
porta_cli_test(features_max_disparity_out_of_range EXIT 1
               STDERR "stereo_max_disparity = 5000: allowed \\[1, 4096\\] \\(set by --max-disparity\\)"
               ARGS features --max-disparity 5000)

# ---- features: bad options -----------------------------------------------------------------------
porta_cli_test(features_levels_not_a_number EXIT 1 STDERR "option --levels expects an integer, got 'abc'"
               ARGS features --levels abc)
porta_cli_test(features_scale_not_a_number EXIT 1 STDERR "option --scale expects a number, got '1\\.2x'"
               ARGS features --scale 1.2x)
porta_cli_test(features_missing_option_value EXIT 1 STDERR "option --levels needs a value" ARGS features --levels)
porta_cli_test(features_option_value_is_an_option EXIT 1 STDERR "option --out needs a value"
               ARGS features --out --levels 4)
porta_cli_test(features_unknown_option EXIT 1 STDERR "unknown option '--frobnicate'" ARGS features --frobnicate)
porta_cli_test(features_negative_threads EXIT 1 STDERR "option --threads expects an integer in \\[0, 256\\], got '-1'" ARGS features --threads -1)
porta_cli_test(features_zero_repeat EXIT 1 STDERR "option --repeat expects a count in \\[1, 10000\\], got 0"
               ARGS features --repeat 0)

# ---- features: backends that cannot be used --------------------------------------------------------
porta_cli_test(features_unknown_backend EXIT 1
               STDERR "unknown backend 'nosuch': choose one of cpu, cuda, vulkan, opencl.*portaslam backends"
               ARGS features --backend nosuch)
foreach(porta_backend cuda vulkan opencl)
  string(TOUPPER ${porta_backend} porta_backend_upper)
  if(NOT PORTA_WITH_${porta_backend_upper})
    porta_cli_test(features_backend_${porta_backend}_not_built EXIT 1
                   STDERR "backend '${porta_backend}' is not built into this binary \\(built: cpu"
                   ARGS features --backend ${porta_backend})
  endif()
endforeach()

# ---- features on real images (skipped when ../shared/data is absent) ------------------------------
set(porta_tsukuba ${PORTA_DATA_DIR}/middlebury/tsukuba)
if(EXISTS ${porta_tsukuba}/im2.png AND EXISTS ${porta_tsukuba}/im6.png)
  porta_cli_test(features_tsukuba_stereo EXIT 0 FILE ${porta_cli_dir}/tsukuba.png
                 STDOUT "384x288, stereo pair.*total +[1-9][0-9]* +[1-9][0-9]* keypoints.*stereo matches: [1-9][0-9]* of"
                 ARGS features ${porta_tsukuba}/im2.png ${porta_tsukuba}/im6.png --out tsukuba.png)
else()
  message(STATUS "PortaSLAM: cli.features_tsukuba_stereo skipped: ${porta_tsukuba}/im2.png not found")
endif()
set(porta_kitti_frame ${PORTA_DATA_DIR}/kitti07-left-head/image_0/000000.png)
if(EXISTS ${porta_kitti_frame})
  porta_cli_test(features_kitti_frame EXIT 0 FILE ${porta_cli_dir}/kitti.png
                 STDOUT "1226x370, single image.*total +[1-9][0-9]* keypoints"
                 ARGS features ${porta_kitti_frame} --out kitti.png)
endif()

# include() shares the includer's scope: leave nothing behind but the tests.
unset(porta_ppm)
unset(porta_rows)
unset(porta_row)
unset(porta_row64)
unset(porta_row80)
unset(porta_line)
unset(porta_a)
unset(porta_b)
unset(porta_square_a)
unset(porta_square_b)
unset(porta_tsukuba)
unset(porta_kitti_frame)
