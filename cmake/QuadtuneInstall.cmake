# `cmake --install build --prefix P`: the module libraries, their public headers, the assets
# (drones, layouts) and a package config, so that another project's
#   find_package(quadtune CONFIG REQUIRED)
# gives quadtune::engine, quadtune::sim, quadtune::planning, quadtune::layout,
# quadtune::optimizers, quadtune::physics and quadtune::common (quadtuneConfig.cmake.in finds
# their dependencies).
# quadtune_add_module() installs each library and its headers; this file adds the rest.
include(CMakePackageConfigHelpers)

set(QUADTUNE_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/quadtune)
set(QUADTUNE_INSTALL_ASSETSDIR ${CMAKE_INSTALL_DATADIR}/quadtune/assets)

install(TARGETS quadtune_warnings quadtune_sanitizers EXPORT quadtuneTargets)
install(EXPORT quadtuneTargets NAMESPACE quadtune:: DESTINATION ${QUADTUNE_INSTALL_CMAKEDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/assets/ DESTINATION ${QUADTUNE_INSTALL_ASSETSDIR})

configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/quadtuneConfig.cmake.in
  ${PROJECT_BINARY_DIR}/quadtuneConfig.cmake
  INSTALL_DESTINATION ${QUADTUNE_INSTALL_CMAKEDIR}
  PATH_VARS QUADTUNE_INSTALL_ASSETSDIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/quadtuneConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/quadtuneConfig.cmake
  ${PROJECT_BINARY_DIR}/quadtuneConfigVersion.cmake
  DESTINATION ${QUADTUNE_INSTALL_CMAKEDIR})

# The Python package `quadtune` goes where the interpreter looks under the prefix: with the
# default prefix /usr/local, Debian's python3 finds lib/python3.X/dist-packages without any
# PYTHONPATH; with --prefix P, PYTHONPATH=P/${QUADTUNE_INSTALL_PYTHONDIR}.
find_package(Python3 REQUIRED COMPONENTS Interpreter)
set(QUADTUNE_INSTALL_PYTHONDIR
  "lib/python${Python3_VERSION_MAJOR}.${Python3_VERSION_MINOR}/dist-packages"
  CACHE PATH "Where cmake --install puts the Python package quadtune, relative to the prefix")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/experiments/python/quadtune
  DESTINATION ${QUADTUNE_INSTALL_PYTHONDIR} PATTERN __pycache__ EXCLUDE)
