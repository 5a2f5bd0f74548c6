# The installable package (docs/extending.md): the layers as rig::core, rig::graph, rig::inversion_model,
# rig::inversion_learn, rig::inversion_solve, rig::inversion_clip (rig::inversion: all four), rig::nodes, rig::adapter
# and rig::app, their headers under include/rig, the programs and the rigInversion plugin, and a rigConfig.cmake that
# finds the dependencies, so that find_package(rig) builds a node plugin or a program against an installed rig.
# The same names exist in the build tree as ALIAS targets, so that code links alike inside and outside.
include(CMakePackageConfigHelpers)

set(RIG_PACKAGE_TARGETS rig_core rig_graph rig_inversion_model rig_inversion_learn rig_inversion_solve
    rig_inversion_clip rig_inversion rig_nodes rig_adapter rig_app)
foreach(target ${RIG_PACKAGE_TARGETS})
  string(REPLACE "rig_" "" name ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name})
  add_library(rig::${name} ALIAS ${target})
endforeach()

install(TARGETS ${RIG_PACKAGE_TARGETS} EXPORT rigTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# The plugin beside the engine's library, where NodeRegistry::loadPlugin looks last (as build/lib in the tree).
install(TARGETS rigInversion LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(TARGETS graph-eval skel2rig rig-learn rig-invert rig-batch RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# bvh2rig, skel2rig's former name, as a relative link beside it.
install(CODE "file(CREATE_LINK skel2rig \"\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_BINDIR}/bvh2rig\" SYMBOLIC)")
foreach(folder core graph inversion nodes adapter app)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${folder} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/rig
          FILES_MATCHING PATTERN "*.h")
endforeach()

set(RIG_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/rig)
install(EXPORT rigTargets NAMESPACE rig:: DESTINATION ${RIG_CMAKE_DIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/rigConfig.cmake.in ${PROJECT_BINARY_DIR}/rigConfig.cmake
  INSTALL_DESTINATION ${RIG_CMAKE_DIR})
# 0.x: a minor version may change the interfaces, so only the same minor version is compatible.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/rigConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/rigConfig.cmake ${PROJECT_BINARY_DIR}/rigConfigVersion.cmake
  DESTINATION ${RIG_CMAKE_DIR})
