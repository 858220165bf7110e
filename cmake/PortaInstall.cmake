# `cmake --install build --prefix P`: headers, the libraries this build made, the portaslam program
# and a CMake package, so that another project writes
#
#   find_package(PortaSLAM 0.1 REQUIRED COMPONENTS slam dataset)   # backends: cpu cuda vulkan opencl
#   target_link_libraries(app PRIVATE PortaSLAM::slam PortaSLAM::dataset)
#
# Targets (namespace PortaSLAM::): engine (frontend, HAL, settings), backends (every backend of the
# build, registered in porta::BackendRegistry), backend_<name>, png (PNG files through libpng),
# slam_core (poses, trajectories, camera), render, optim, slam (tracking, mapping, loop closing),
# eval (ATE, RPE, KITTI metric), dataset (KITTI / EuRoC / folder readers). The libraries are
# static; the package finds what they link (Eigen, Ceres, libpng, OpenCV, Vulkan, OpenCL, CUDA)
# the way this build did. docs/API.md shows the C++ API.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(porta_cmake_dir ${CMAKE_INSTALL_LIBDIR}/cmake/PortaSLAM)

# Library target -> exported name (PortaSLAM::<name>) and component, for those this build has.
set(porta_install_targets "")
set(porta_components "")
macro(porta_export target name component)
  if(TARGET ${target})
    set_target_properties(${target} PROPERTIES EXPORT_NAME ${name})
    list(APPEND porta_install_targets ${target})
    list(APPEND porta_components ${component})
  endif()
endmacro()
porta_export(porta_engine engine engine)
foreach(b cpu cuda vulkan opencl)
  porta_export(porta_backend_${b} backend_${b} ${b})
endforeach()
porta_export(porta_backends backends backends)
foreach(part png slam_core render optim slam eval dataset)
  porta_export(porta_${part} ${part} ${part})
endforeach()
# Our warning flags are PRIVATE to every library; for static libraries CMake still records them
# as link-only dependencies (their link options matter in sanitizer builds), so they are exported.
set_target_properties(porta_warnings PROPERTIES EXPORT_NAME warnings)

install(TARGETS ${porta_install_targets} porta_warnings EXPORT PortaSLAMTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
if(TARGET portaslam)
  install(TARGETS portaslam EXPORT PortaSLAMTargets RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()

install(DIRECTORY ${PROJECT_SOURCE_DIR}/engine/include/porta DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
if(TARGET porta_slam_core)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/slam/include/porta DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endif()
if(TARGET porta_png)
  install(FILES ${PROJECT_SOURCE_DIR}/imageio/png_file.hpp DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/porta/imageio)
endif()

install(EXPORT PortaSLAMTargets NAMESPACE PortaSLAM:: DESTINATION ${porta_cmake_dir})

# What the package must find again for the consumer (the libraries' link dependencies).
foreach(flag PNG Deflate Ceres OpenCV)
  set(PORTA_PACKAGE_NEEDS_${flag} OFF)
endforeach()
if(TARGET porta_png)
  set(PORTA_PACKAGE_NEEDS_PNG ON)
  if(PortaDeflate_FOUND)
    set(PORTA_PACKAGE_NEEDS_Deflate ON)
    install(FILES ${PROJECT_SOURCE_DIR}/cmake/PortaDeflate.cmake DESTINATION ${porta_cmake_dir})
  endif()
endif()
if(TARGET porta_optim)
  set(PORTA_PACKAGE_NEEDS_Ceres ON)
endif()
if(OpenCV_FOUND AND (TARGET porta_eval OR TARGET porta_dataset))
  set(PORTA_PACKAGE_NEEDS_OpenCV ON)
  install(FILES ${PROJECT_SOURCE_DIR}/cmake/PortaOpenCV.cmake DESTINATION ${porta_cmake_dir})
endif()
set(PORTA_PACKAGE_COMPONENTS ${porta_components})

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/PortaSLAMConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/PortaSLAMConfig.cmake
                              INSTALL_DESTINATION ${porta_cmake_dir})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/PortaSLAMConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/PortaSLAMConfig.cmake ${PROJECT_BINARY_DIR}/PortaSLAMConfigVersion.cmake
        DESTINATION ${porta_cmake_dir})
