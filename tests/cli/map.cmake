# CLI tests of `portaslam map info` (label: cli): every kind of bad map file is exit status 1 with
# the loader's message on stderr, a usage mistake exit status 2. (A test on a real saved map comes
# with `portaslam run --save-map`.) porta_cli_test() and porta_cli_dir come from features.cmake,
# included before this file.
if(NOT TARGET porta_slam)
  return()
endif()

file(WRITE ${porta_cli_dir}/empty.pmap "")
file(WRITE ${porta_cli_dir}/garbage.pmap "This is a text file, not a map.\n")
file(WRITE ${porta_cli_dir}/cut.pmap "PORTAMAP")  # the magic alone: cut inside the header

porta_cli_test(help_map EXIT 0 STDOUT "Usage: portaslam map info FILE.*checksums" ARGS help map)
porta_cli_test(map_info_help EXIT 0 STDOUT "Usage: portaslam map info FILE" ARGS map info --help)
porta_cli_test(map_no_subcommand EXIT 2 STDERR "portaslam map: no subcommand given.*Usage: portaslam map info FILE"
               ARGS map)
porta_cli_test(map_unknown_subcommand EXIT 2 STDERR "portaslam map: unknown subcommand 'show'" ARGS map show x.pmap)
porta_cli_test(map_info_no_file EXIT 2 STDERR "portaslam map info: expected one FILE, got none" ARGS map info)
porta_cli_test(map_info_two_files EXIT 2 STDERR "expected one FILE, got 2 arguments" ARGS map info a.pmap b.pmap)
porta_cli_test(map_info_missing EXIT 1
               STDERR "portaslam map info: map file 'no_such\\.pmap': cannot open: no such file" ARGS map info no_such.pmap)
porta_cli_test(map_info_empty EXIT 1 STDERR "map file 'empty\\.pmap': the file is empty \\(0 bytes\\), not a PortaSLAM map file"
               ARGS map info empty.pmap)
porta_cli_test(map_info_garbage EXIT 1 STDERR "map file 'garbage\\.pmap': not a PortaSLAM map file" ARGS map info garbage.pmap)
porta_cli_test(map_info_truncated EXIT 1 STDERR "map file 'cut\\.pmap': truncated: the file ends at offset 8" ARGS map info cut.pmap)
porta_cli_test(map_info_directory EXIT 1 STDERR "map file '\\.': cannot read: it is a directory" ARGS map info .)
