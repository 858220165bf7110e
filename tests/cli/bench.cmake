# CLI tests of `portaslam bench` (label: cli): a tiny run of the throughput matrix prints the table
# with a cpu row and an OpenCV peer row, --json writes the numbers, a folder without data falls
# back to the synthetic image and says so, and every bad value fails with a clear message and exit
# status 1. Each run is a few frames of one cell, well under 5 s. The default backends are cpu and
# every other one available here, so other backends' rows may come between cpu's and the peer's.
#
# porta_cli_test() and porta_cli_dir come from features.cmake, which tests/CMakeLists.txt includes
# after this file (alphabetical order), so the tests are declared at the end of the directory.

# A backend switch (an environment variable read when the backend is made) set to a value it does
# not take: bench exits 1 naming the backend, the variable and the value. The test is named for the
# variable: PORTA_VULKAN_QUEUES=9 is cli.bench_vulkan_queues_bad_value. `tiny` is the caller's.
function(porta_bench_bad_switch variable value expect)
  string(REGEX MATCH "^PORTA_([A-Z]+)_(.+)$" matched "${variable}")
  string(TOLOWER "${CMAKE_MATCH_1}" backend)
  string(TOLOWER "${CMAKE_MATCH_2}" switch)
  porta_cli_test(bench_${backend}_${switch}_bad_value EXIT 1
                 STDERR "${backend}: ${variable} ${expect}, got '${value}'"
                 ARGS bench ${tiny} --backend ${backend} --no-peer)
  set_tests_properties(cli.bench_${backend}_${switch}_bad_value PROPERTIES ENVIRONMENT ${variable}=${value})
endfunction()

function(porta_bench_cli_tests)
  set(tiny --frames 3 --warmup 1 --resolutions 320x240 --levels 1 --modes detect)
  file(MAKE_DIRECTORY ${porta_cli_dir}/bench_no_data)

  # ---- Runs that succeed ---------------------------------------------------------------------------
  porta_cli_test(help_bench EXIT 0 STDOUT "Usage: portaslam bench.*--resolutions LIST.*--no-peer" ARGS help bench)
  porta_cli_test(bench_help EXIT 0 STDOUT "Usage: portaslam bench.*--frames N" ARGS bench --help)
  porta_cli_test(bench_tiny EXIT 0
                 STDOUT "backend   cpu: cpu \\(.*peer      opencv-orb: OpenCV .*input     320x240 +(KITTI|EuRoC|SYNTHETIC).*\nbackend +resolution +levels +mode +median_us +p10_us +p90_us +mean_us +frames/s +keypoints +matches +speedup\ncpu +320x240 +1 +detect +[0-9]+ +[0-9]+ +[0-9]+ +[0-9]+ +[0-9.]+ +[0-9]+ +- +[0-9.]+x\n(.*\n)?opencv-orb +320x240 +1 +detect +[0-9]+ +[0-9]+ +[0-9]+ +[0-9]+ +[0-9.]+ +[0-9]+ +- +-\n"
                 STDERR "\\[1/[0-9]+\\] cpu +320x240 +levels 1 detect +median.*\\[[0-9]+/[0-9]+\\] opencv-orb"
                 ARGS bench ${tiny})
  porta_cli_test(bench_json EXIT 0 FILE ${porta_cli_dir}/bench.json STDOUT "wrote bench.json"
                 ARGS bench ${tiny} --backend cpu --json bench.json)
  set_tests_properties(cli.bench_json PROPERTIES FIXTURES_SETUP porta_bench_json)
  # The file itself (read back with `cmake -E cat`): the per-cell numbers and the context.
  add_test(NAME cli.bench_json_content
           COMMAND ${CMAKE_COMMAND} -DEXPECT_EXIT=0
                   "-DEXPECT_STDOUT=\"commit\": \"[^\"]+\".*\"cpu_model\".*\"results\": \\[.*\"backend\": \"cpu\", \"resolution\": \"320x240\".*\"median_us\": [0-9.e+]+, \"p10_us\".*\"speedup_vs_peer\": [0-9.e+-]+.*\"backend\": \"opencv-orb\""
                   -P ${porta_cli_checker} -- ${CMAKE_COMMAND} -E cat bench.json
           WORKING_DIRECTORY ${porta_cli_dir})
  set_tests_properties(cli.bench_json_content PROPERTIES LABELS cli FIXTURES_REQUIRED porta_bench_json)
  porta_cli_test(bench_synthetic_without_data EXIT 0
                 STDOUT "input     640x480 +SYNTHETIC input \\(no KITTI or EuRoC frames in .*bench_no_data\\).*\ncpu +640x480 +1 +stereo +[0-9]+"
                 ARGS bench --frames 2 --warmup 0 --resolutions 640x480 --levels 1 --modes stereo --no-peer
                      --backend cpu --data bench_no_data)

  # Frames in flight: the cpu backend runs frames in order, so --in-flight 4 adds no cpu/4 row (the
  # table has the one cpu row, then the footnote).
  porta_cli_test(bench_in_flight_in_order_backend EXIT 0
                 STDOUT "rows BACKEND/N: throughput.*
cpu +320x240 +1 +detect +[0-9]+ +[0-9]+ +[0-9]+ +[0-9]+ +[0-9.]+ +[0-9]+ +- +-

frames/s"
                 ARGS bench ${tiny} --backend cpu --no-peer --in-flight 1,4)
  # Pinned input images: one more row per backend, labelled +pin.
  porta_cli_test(bench_pinned_input EXIT 0
                 STDOUT "
cpu +320x240 +1 +detect +[0-9]+ .*
cpu\\+pin +320x240 +1 +detect +[0-9]+ +[0-9]+ +[0-9]+ +[0-9]+ +[0-9.]+ +[0-9]+ +- +-

frames/s"
                 ARGS bench ${tiny} --backend cpu --no-peer --input copy,pinned)

  # ---- Bad input: exit 1 and a message naming the option and what it accepts ----------------------
  porta_cli_test(bench_in_flight_out_of_range EXIT 1
                 STDERR "option --in-flight expects frame counts in \\[1, 16\\], got 17" ARGS bench --in-flight 1,17)
  porta_cli_test(bench_unknown_input EXIT 1 STDERR "unknown input 'mmap' in --input: choose from copy, pinned"
                 ARGS bench --input pinned,mmap)
  porta_cli_test(bench_in_flight_not_a_number EXIT 1 STDERR "option --in-flight expects an integer, got 'all'"
                 ARGS bench --in-flight all)
  porta_cli_test(bench_unknown_backend EXIT 1
                 STDERR "portaslam bench: unknown backend 'nosuch': choose one of cpu, cuda, vulkan, opencl.*portaslam backends"
                 ARGS bench ${tiny} --backend cpu,nosuch)
  foreach(backend cuda vulkan opencl)  # one that this build lacks, when there is one
    string(TOUPPER ${backend} upper)
    if(NOT PORTA_WITH_${upper})
      porta_cli_test(bench_backend_not_built EXIT 1
                     STDERR "portaslam bench: backend '${backend}' is not built into this binary \\(built: cpu"
                     ARGS bench ${tiny} --backend ${backend})
      break()
    endif()
  endforeach()
  # --profile-kernels: the per-kernel section follows the table; a backend that does not time its
  # kernels says so (the vulkan and opencl tables are tested in tests/unit/kernel_profile_test.cpp).
  porta_cli_test(bench_profile_kernels_cpu EXIT 0
                 STDOUT "Per-kernel device time.*\ncpu, 320x240, 1 levels, detect, 3 frames\n  no per-kernel device timing on this backend"
                 ARGS bench ${tiny} --backend cpu --no-peer --profile-kernels)
  porta_cli_test(bench_profile_kernels_takes_no_value EXIT 1 STDERR "option --profile-kernels takes no value"
                 ARGS bench --profile-kernels=yes)
  if(TARGET porta_backend_opencl)  # PoCL in CI; the value is checked when the backend is made
    porta_bench_bad_switch(PORTA_OPENCL_WORK_GROUPS maybe "must be on or off")
    porta_bench_bad_switch(PORTA_OPENCL_QUEUES 0 "must be a queue count from 1 to 8")
    porta_bench_bad_switch(PORTA_OPENCL_FUSED_PYRAMID 1 "must be on or off")
    porta_bench_bad_switch(PORTA_OPENCL_PFA_IN_CULL maybe "must be on or off")
  endif()
  # porta_cl_enqueue_bench (bench/opencl) names a device it cannot find and exits 2.
  if(TARGET porta_cl_enqueue_bench)
    add_test(NAME cli.cl_enqueue_bench_missing_device
             COMMAND ${CMAKE_COMMAND} -DEXPECT_EXIT=2
                     "-DEXPECT_STDERR=porta_cl_enqueue_bench: PORTA_OPENCL_DEVICE 'no such device' names no device"
                     -P ${porta_cli_checker} -- $<TARGET_FILE:porta_cl_enqueue_bench>
             WORKING_DIRECTORY ${porta_cli_dir})
    set_tests_properties(cli.cl_enqueue_bench_missing_device PROPERTIES LABELS cli TIMEOUT 300
                         ENVIRONMENT "PORTA_OPENCL_DEVICE=no such device")
  endif()
  if(TARGET porta_backend_vulkan)  # lavapipe in CI
    porta_bench_bad_switch(PORTA_VULKAN_WORK_GROUPS yes "must be on or off")
    porta_bench_bad_switch(PORTA_VULKAN_QUEUES 9 "must be a queue count from 1 to 8")
    porta_bench_bad_switch(PORTA_VULKAN_FUSED_PYRAMID yes "must be on or off")
    porta_bench_bad_switch(PORTA_VULKAN_PFA_IN_CULL maybe "must be on or off")
    porta_bench_bad_switch(PORTA_VULKAN_CULL_FINISHES 2 "must be on or off")
    porta_bench_bad_switch(PORTA_VULKAN_ALL_BARRIERS always "must be on or off")
    porta_bench_bad_switch(PORTA_VULKAN_FENCE_POLL_US 1ms "must be a time in microseconds from 0 to 1000000")
    porta_bench_bad_switch(PORTA_VULKAN_HOLD_BATCHES 5 "must be on, off or a batch count from 1 to 4")
    porta_bench_bad_switch(PORTA_VULKAN_DEVICE_QUEUES two "must be a count from 1 to 8")
    porta_bench_bad_switch(PORTA_VULKAN_PARAMS_MEMORY bar "must be host or device")
  endif()
  porta_cli_test(bench_frames_zero EXIT 1
                 STDERR "portaslam bench: option --frames expects a count in \\[1, 1000000\\], got 0" ARGS bench --frames 0)
  porta_cli_test(bench_frames_negative EXIT 1
                 STDERR "option --frames expects a count in \\[1, 1000000\\], got -5" ARGS bench --frames -5)
  porta_cli_test(bench_frames_not_a_number EXIT 1 STDERR "option --frames expects an integer, got 'many'"
                 ARGS bench --frames many)
  porta_cli_test(bench_frames_missing_value EXIT 1 STDERR "option --frames needs a value" ARGS bench --frames)
  porta_cli_test(bench_warmup_negative EXIT 1
                 STDERR "option --warmup expects a count in \\[0, 1000000\\], got -1" ARGS bench --warmup=-1)
  porta_cli_test(bench_threads_negative EXIT 1 STDERR "option --threads expects an integer in \\[0, 256\\], got '-2'" ARGS bench --threads -2)
  porta_cli_test(bench_resolution_not_wxh EXIT 1
                 STDERR "option --resolutions expects sizes WxH separated by commas \\(e.g. 640x480,1242x375\\), got '640by480'"
                 ARGS bench --resolutions 320x240,640by480)
  porta_cli_test(bench_resolution_too_small EXIT 1
                 STDERR "option --resolutions: size 16x16 is out of range: each side must be in \\[40, 16384\\]"
                 ARGS bench --resolutions 16x16)
  porta_cli_test(bench_unknown_mode EXIT 1
                 STDERR "unknown mode 'track' in --modes: choose from detect, extract, stereo"
                 ARGS bench --modes detect,track)
  porta_cli_test(bench_levels_out_of_range EXIT 1
                 STDERR "invalid setting levels = 13: allowed \\[1, 12\\] \\(set by --levels\\)" ARGS bench --levels 1,13)
  porta_cli_test(bench_empty_list EXIT 1 STDERR "option --modes needs at least one value, got ','"
                 ARGS bench --modes ,)
  porta_cli_test(bench_unknown_option EXIT 1
                 STDERR "unknown option '--frobnicate' \\(see `portaslam bench --help`\\)" ARGS bench --frobnicate)
  porta_cli_test(bench_unexpected_argument EXIT 1 STDERR "unexpected argument 'image.png': bench takes options only"
                 ARGS bench image.png)
  porta_cli_test(bench_no_peer_value EXIT 1 STDERR "option --no-peer takes no value" ARGS bench --no-peer=1)
  porta_cli_test(bench_data_folder_missing EXIT 1
                 STDERR "data folder 'no/such/folder' \\(from --data\\) is not a folder" ARGS bench ${tiny} --data no/such/folder)
  porta_cli_test(bench_json_folder_missing EXIT 1
                 STDERR "option --json: cannot write 'no/such/bench.json': the folder 'no/such' does not exist"
                 ARGS bench ${tiny} --json no/such/bench.json)
endfunction()

cmake_language(DEFER CALL porta_bench_cli_tests)
