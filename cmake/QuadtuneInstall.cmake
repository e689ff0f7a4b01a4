# `cmake --install build --prefix P`: the program P/bin/quadtune with its figure and report
# scripts (P/share/quadtune/experiments/{plot,report}, the report's JavaScript libraries
# included), the Python package quadtune, the module libraries, their public headers, the assets
# (drones, layouts) and a package config, so that another project's
#   find_package(quadtune CONFIG REQUIRED)
# gives quadtune::engine, quadtune::sim, quadtune::planning, quadtune::layout,
# quadtune::optimizers, quadtune::physics and quadtune::common (quadtuneConfig.cmake.in finds
# their dependencies).
# quadtune_add_module() installs each library and its headers; this file adds the rest.
include(CMakePackageConfigHelpers)

set(QUADTUNE_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/quadtune)
set(QUADTUNE_INSTALL_DATA ${CMAKE_INSTALL_DATADIR}/quadtune)
set(QUADTUNE_INSTALL_ASSETSDIR ${QUADTUNE_INSTALL_DATA}/assets)

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

# The program finds its scripts, the report's libraries, the assets and the package under its
# prefix (experiments/program_paths.hpp): the layout, relative to the prefix, compiled in.
install(TARGETS quadtune RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
set(QUADTUNE_LAYOUT_DEFINITIONS QUADTUNE_INSTALL_BINDIR="${CMAKE_INSTALL_BINDIR}"
  QUADTUNE_INSTALL_DATADIR="${CMAKE_INSTALL_DATADIR}"
  QUADTUNE_INSTALL_PYTHONDIR="${QUADTUNE_INSTALL_PYTHONDIR}")
set_source_files_properties(${PROJECT_SOURCE_DIR}/experiments/program_paths.cpp
  DIRECTORY ${PROJECT_SOURCE_DIR}/experiments
  PROPERTIES COMPILE_DEFINITIONS "${QUADTUNE_LAYOUT_DEFINITIONS}")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/experiments/plot/
  DESTINATION ${QUADTUNE_INSTALL_DATA}/experiments/plot FILES_MATCHING PATTERN "*.py"
  PATTERN __pycache__ EXCLUDE)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/experiments/report/
  DESTINATION ${QUADTUNE_INSTALL_DATA}/experiments/report
  PATTERN js EXCLUDE PATTERN __pycache__ EXCLUDE)
# Of the report's JavaScript libraries (scripts/setup.sh installs them with `npm ci`), the files
# quadtune_report.py inlines, with their licences; test/install/install_tool.sh writes a report
# from the install, so a file missing here fails there.
set(QUADTUNE_REPORT_JS_FILES
  plotly.js-dist-min/plotly.min.js plotly.js-dist-min/LICENSE plotly.js-dist-min/package.json
  three/build/three.core.js three/build/three.module.js
  three/examples/jsm/controls/OrbitControls.js three/LICENSE three/package.json)
set(QUADTUNE_REPORT_JS_DIR ${PROJECT_SOURCE_DIR}/experiments/report/js/node_modules)
if(NOT EXISTS ${QUADTUNE_REPORT_JS_DIR}/three/build/three.module.js)
  message(STATUS "quadtune: ${QUADTUNE_REPORT_JS_DIR} is not installed (run scripts/setup.sh); "
    "cmake --install will install no report libraries, and the installed `quadtune report` "
    "will need $QUADTUNE_REPORT_JS")
endif()
foreach(file IN LISTS QUADTUNE_REPORT_JS_FILES)
  get_filename_component(dir ${file} DIRECTORY)
  install(FILES ${QUADTUNE_REPORT_JS_DIR}/${file} OPTIONAL
    DESTINATION ${QUADTUNE_INSTALL_DATA}/experiments/report/js/node_modules/${dir})
endforeach()
