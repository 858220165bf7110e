# Finds the OpenCV modules PortaSLAM uses. Debian ships OpenCV's CMake package only with the full
# libopencv-dev (which pulls in every module and its GUI stack); ci/setup.sh installs just the
# modules we need, so when the CMake package is absent we locate their headers and libraries here.
# Result: OpenCV_FOUND and OpenCV_LIBS (imported targets).
#
# -DPORTA_FORCE_NO_OPENCV=ON builds as if OpenCV were absent (OpenCV_FOUND false), to check on a
# development machine what a machine without OpenCV C++ (the GPU machine) builds and runs.
option(PORTA_FORCE_NO_OPENCV "Build as if OpenCV were not installed" OFF)
if(PORTA_FORCE_NO_OPENCV)
  set(OpenCV_FOUND FALSE)
  set(OpenCV_LIBS "")
  message(STATUS "PortaSLAM: OpenCV ignored (PORTA_FORCE_NO_OPENCV=ON)")
  return()
endif()
set(_porta_cv_modules core imgproc imgcodecs features2d calib3d flann)
find_package(OpenCV QUIET CONFIG COMPONENTS core imgproc imgcodecs features2d calib3d)
if(NOT OpenCV_FOUND)
  find_path(PORTA_OPENCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4)
  set(OpenCV_LIBS "")
  set(OpenCV_FOUND TRUE)
  if(NOT PORTA_OPENCV_INCLUDE_DIR)
    set(OpenCV_FOUND FALSE)
  endif()
  foreach(m ${_porta_cv_modules})
    find_library(PORTA_OPENCV_${m}_LIBRARY opencv_${m})
    if(NOT PORTA_OPENCV_${m}_LIBRARY)
      set(OpenCV_FOUND FALSE)
    elseif(NOT TARGET porta_opencv_${m})
      add_library(porta_opencv_${m} SHARED IMPORTED)
      set_target_properties(porta_opencv_${m} PROPERTIES
        IMPORTED_LOCATION ${PORTA_OPENCV_${m}_LIBRARY}
        INTERFACE_INCLUDE_DIRECTORIES ${PORTA_OPENCV_INCLUDE_DIR})
      list(APPEND OpenCV_LIBS porta_opencv_${m})
    endif()
  endforeach()
endif()
if(OpenCV_FOUND)
  message(STATUS "PortaSLAM: OpenCV found (${OpenCV_LIBS})")
endif()
