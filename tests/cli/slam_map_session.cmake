# A save / load / localise session (docs/USER_GUIDE.md, "Loops, relocalisation and maps"): a short
# rendered street is mapped and saved, the map is inspected, a localisation-only pass over the same
# frames relocalises on the first frame and tracks every frame without adding a keyframe, a second
# mapping pass continues on the map, and bad map inputs are refused before any work.
# Run as a script by run.cmake: cmake -DPORTASLAM=... -DWORK=... -P slam_map_session.cmake
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

portaslam(0 render --count 40 --out seq --quiet)
portaslam(0 run --dataset kitti seq --mode deterministic --out first --save-map first/map.pmap --quiet)
require("${out}" "frames 40, tracked 40, lost 0; keyframes ([0-9]+)" "first pass")
string(REGEX MATCH "keyframes ([0-9]+)" unused "${out}")
set(keyframes ${CMAKE_MATCH_1})
require("${out}" "map       saved to first/map.pmap" "first pass")

portaslam(0 map info first/map.pmap)
require("${out}" "keyframes +${keyframes}" "map info")

# Localisation only: relocalised at the first frame, every frame tracked, nothing added.
portaslam(0 run --dataset kitti seq --mode deterministic --load-map first/map.pmap --localization --out loc --quiet)
require("${out}" "map       first/map.pmap: ${keyframes} keyframes.*localisation only" "localisation pass")
require("${out}" "frames 40, tracked 40, lost 0; keyframes ${keyframes}," "localisation pass")
require("${out}" "relocalisations: 1 at frames 0" "localisation pass")
require("${err}" "frame 0: relocalised at frame 0 against keyframe" "localisation pass")

# Mapping continues on the loaded map (new keyframes get ids after the map's).
portaslam(0 run --dataset kitti seq --mode deterministic --load-map first/map.pmap --out more
          --save-map more/map.pmap --quiet)
require("${out}" "frames 40, tracked 40, lost 0" "second mapping pass")
portaslam(0 map info more/map.pmap)

# Refused before any work.
portaslam(1 run --dataset kitti seq --localization --out bad)
require("${err}" "--localization tracks on a saved map: give it with --load-map FILE" "localisation without a map")
portaslam(1 run --dataset kitti seq --out bad --save-map no_such_folder/map.pmap)
require("${err}" "cannot write 'no_such_folder/map.pmap': the folder 'no_such_folder' does not exist" "save-map folder")
file(WRITE ${WORK}/garbage.pmap "not a map at all")
portaslam(1 run --dataset kitti seq --out bad --load-map garbage.pmap)
require("${err}" "map file 'garbage.pmap': not a PortaSLAM map file" "garbage map")
portaslam(0 render --count 3 --size 621x188 --out small --quiet)
portaslam(1 run --dataset kitti small --out bad --load-map first/map.pmap)
require("${err}" "map file 'first/map.pmap': the map was made with the camera 1242x375.*this camera is 621x188" "other camera")
message(STATUS "map session: saved, inspected, localised (${keyframes} keyframes kept), continued, bad inputs refused")
