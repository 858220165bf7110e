# `portaslam run --export-map` on a short rendered street (docs/USER_GUIDE.md, "Map export and the
# top view"): the PLY is binary little-endian PLY 1.0 of exactly header + 15 bytes per vertex, its
# vertex count is the one the summary (text and summary.json) reports, the top view is a PNG; the
# saved map exported by `portaslam map export` has the same vertices; a localisation-only run on it
# exports the same map again; bad outputs are refused before any work, leaving no file.
# Run as a script by map_export.cmake: cmake -DPORTASLAM=... -DWORK=... -P slam_map_export.cmake
if(NOT CMAKE_SCRIPT_MODE_FILE)
  return()
endif()
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})

function(portaslam expect_rc)
  execute_process(COMMAND ${PORTASLAM} ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err
                  WORKING_DIRECTORY ${WORK})
  if(NOT rc EQUAL expect_rc)
    message(FATAL_ERROR "portaslam ${ARGN}: exit ${rc}, expected ${expect_rc}:\n${out}${err}")
  endif()
  set(out "${out}" PARENT_SCOPE)
  set(err "${err}" PARENT_SCOPE)
endfunction()

function(require text pattern what)
  if(NOT text MATCHES "${pattern}")
    message(FATAL_ERROR "${what}: expected /${pattern}/ in:\n${text}")
  endif()
endfunction()

# Reads a PLY's header and checks the layout; sets <prefix>_vertices.
function(check_ply path prefix)
  if(NOT EXISTS ${WORK}/${path})
    message(FATAL_ERROR "${path} was not written")
  endif()
  file(READ ${WORK}/${path} head LIMIT 1024 HEX)
  string(FIND "${head}" "656e645f6865616465720a" end_hex)  # "end_header\n"
  if(end_hex LESS 0)
    message(FATAL_ERROR "${path}: no end_header in the first 1024 bytes")
  endif()
  math(EXPR header_bytes "(${end_hex} + 22) / 2")
  file(READ ${WORK}/${path} header LIMIT ${header_bytes})
  require("${header}" "^ply\nformat binary_little_endian 1\\.0\n" "${path} header")
  require("${header}" "\nelement vertex ([0-9]+)\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n$"
          "${path} header")
  string(REGEX MATCH "element vertex ([0-9]+)" unused "${header}")
  set(vertices ${CMAKE_MATCH_1})
  file(SIZE ${WORK}/${path} size)
  math(EXPR expected "${header_bytes} + 15 * ${vertices}")
  if(NOT size EQUAL expected)
    message(FATAL_ERROR "${path}: ${size} bytes; header ${header_bytes} + 15 x ${vertices} vertices = ${expected}")
  endif()
  set(${prefix}_vertices ${vertices} PARENT_SCOPE)
endfunction()

portaslam(0 render --count 30 --out seq --quiet)
portaslam(0 run --dataset kitti seq --mode deterministic --out run --export-map run/map.ply --save-map run/map.pmap --quiet)
require("${out}" "frames 30, tracked 30, lost 0; keyframes ([0-9]+), map points ([0-9]+)" "run")
string(REGEX MATCH "keyframes ([0-9]+), map points ([0-9]+)" unused "${out}")
set(keyframes ${CMAKE_MATCH_1})
set(points ${CMAKE_MATCH_2})
math(EXPR vertices "${points} + ${keyframes}")
require("${out}" "map export  run/map\\.ply: ${vertices} vertices \\(${points} map points \\+ ${keyframes} keyframe centres\\), coloured by height"
        "run summary")
require("${out}" "top view    run/map_top\\.png \\([0-9]+x[0-9]+: map points, estimate, ground truth\\)" "run summary")

check_ply(run/map.ply run)
if(NOT run_vertices EQUAL vertices)
  message(FATAL_ERROR "run/map.ply has ${run_vertices} vertices, the summary says ${vertices}")
endif()
file(READ ${WORK}/run/summary.json json)
string(JSON json_vertices GET "${json}" map_export vertices)
string(JSON json_points GET "${json}" map_export map_points)
string(JSON json_map_points GET "${json}" map_points)
string(JSON json_colour GET "${json}" map_export colour)
string(JSON json_top GET "${json}" top_view)
if(NOT json_vertices EQUAL run_vertices OR NOT json_points EQUAL json_map_points OR NOT json_colour STREQUAL "height"
   OR NOT json_top STREQUAL "run/map_top.png")
  message(FATAL_ERROR "summary.json map_export ${json_vertices} vertices, ${json_points} points (map_points "
                      "${json_map_points}), colour ${json_colour}, top_view ${json_top}; the PLY has ${run_vertices}")
endif()
file(READ ${WORK}/run/map_top.png signature LIMIT 8 HEX)
if(NOT signature STREQUAL "89504e470d0a1a0a")
  message(FATAL_ERROR "run/map_top.png is not a PNG file (starts with ${signature})")
endif()

# The saved map, exported by `map export`, coloured by keyframe: the same vertices.
portaslam(0 map export run/map.pmap by_keyframe.ply --colour keyframe)
require("${out}" "map export  by_keyframe\\.ply: ${vertices} vertices .*coloured by keyframe" "map export")
check_ply(by_keyframe.ply saved)
if(NOT saved_vertices EQUAL vertices)
  message(FATAL_ERROR "map export gave ${saved_vertices} vertices, the run ${vertices}")
endif()

# Localisation only on the saved map: nothing is added, so the export is the same size.
portaslam(0 run --dataset kitti seq --frames 5 --load-map run/map.pmap --localization --out loc
          --export-map loc/map.ply --export-map-colour keyframe --quiet)
require("${out}" "map export  loc/map\\.ply: ${vertices} vertices .*coloured by keyframe" "localisation run")
check_ply(loc/map.ply loc)

# Refused before any work, no file left: a folder that does not exist, a folder for a file, a bad colour.
portaslam(1 run --dataset kitti seq --out bad1 --export-map no_such_folder/map.ply)
require("${err}" "option --export-map: cannot write 'no_such_folder/map\\.ply': the folder 'no_such_folder' does not exist"
        "export into a missing folder")
portaslam(1 run --dataset kitti seq --out bad2 --export-map run)
require("${err}" "option --export-map: 'run' is a folder, not a file" "export onto a folder")
portaslam(1 run --dataset kitti seq --out bad3 --export-map bad3.ply --export-map-colour rainbow)
require("${err}" "--export-map-colour must be height or keyframe, got 'rainbow'" "bad colour")
portaslam(2 map export run/map.pmap bad4.ply --colour rainbow)
require("${err}" "--colour must be height or keyframe, got 'rainbow'" "map export bad colour")
portaslam(1 map export no_such.pmap bad5.ply)
require("${err}" "map file 'no_such\\.pmap': cannot open" "map export missing map")
file(GLOB left ${WORK}/bad* ${WORK}/no_such_folder ${WORK}/*.tmp.*)
if(left)
  message(FATAL_ERROR "refused runs left files behind: ${left}")
endif()
message(STATUS "map export: ${vertices} vertices (${points} points + ${keyframes} keyframes) in the PLY, the summary "
               "and summary.json; map export and localisation agree; bad outputs refused")
