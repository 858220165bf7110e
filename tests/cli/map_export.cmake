# CLI test of the map export and the top view (label: cli): slam_map_export.cmake, as a script.
if(NOT TARGET porta_slam OR NOT TARGET porta_dataset OR NOT TARGET porta_render)
  return()
endif()
add_test(NAME cli.run_export_map_ply_and_top_view
         COMMAND ${CMAKE_COMMAND} -DPORTASLAM=$<TARGET_FILE:portaslam> -DWORK=${porta_cli_dir}/map-export
                 -P ${CMAKE_CURRENT_LIST_DIR}/slam_map_export.cmake)
set_tests_properties(cli.run_export_map_ply_and_top_view PROPERTIES LABELS cli TIMEOUT 600)
porta_cli_test(run_export_map_bad_colour EXIT 1 STDERR "--export-map-colour must be height or keyframe, got 'blue'"
               ARGS run --dataset kitti x --export-map x.ply --export-map-colour blue)
porta_cli_test(run_export_map_colour_without_value EXIT 1 STDERR "option --export-map-colour needs a value"
               ARGS run --dataset kitti x --export-map-colour)
porta_cli_test(map_export_no_files EXIT 2 STDERR "portaslam map export: expected a map FILE and an OUT\\.ply, got 0 arguments"
               ARGS map export)
