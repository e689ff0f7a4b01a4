# Compile options shared by every quadtune target, kept in interface targets (no global flags).

include(GNUInstallDirs)

add_library(quadtune_warnings INTERFACE)
add_library(quadtune::warnings ALIAS quadtune_warnings)
set_target_properties(quadtune_warnings PROPERTIES EXPORT_NAME warnings)
target_compile_options(quadtune_warnings INTERFACE
  $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
    -Wold-style-cast -Wcast-align -Woverloaded-virtual -Wnull-dereference -Wdouble-promotion
    -Wformat=2 -Wimplicit-fallthrough>)

add_library(quadtune_sanitizers INTERFACE)
add_library(quadtune::sanitizers ALIAS quadtune_sanitizers)
set_target_properties(quadtune_sanitizers PROPERTIES EXPORT_NAME sanitizers)
if(QUADTUNE_SANITIZE STREQUAL "address")
  target_compile_options(quadtune_sanitizers INTERFACE -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  target_link_options(quadtune_sanitizers INTERFACE -fsanitize=address,undefined)
elseif(QUADTUNE_SANITIZE STREQUAL "thread")
  target_compile_options(quadtune_sanitizers INTERFACE -fsanitize=thread -fno-omit-frame-pointer)
  target_link_options(quadtune_sanitizers INTERFACE -fsanitize=thread)
elseif(NOT QUADTUNE_SANITIZE STREQUAL "")
  message(FATAL_ERROR "QUADTUNE_SANITIZE must be '', 'address' or 'thread', got '${QUADTUNE_SANITIZE}'")
endif()

# quadtune_add_module(NAME SOURCES ... DEPS ...)
# One library per module: target quadtune_<NAME>, alias quadtune::<NAME>, public headers in
# <module>/include/quadtune/<NAME>/. The library and its headers are installed and exported as
# quadtune::<NAME> (cmake/QuadtuneInstall.cmake).
function(quadtune_add_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(quadtune_${name} ${ARG_SOURCES})
  add_library(quadtune::${name} ALIAS quadtune_${name})
  target_include_directories(quadtune_${name} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_compile_features(quadtune_${name} PUBLIC cxx_std_20)
  set_target_properties(quadtune_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON EXPORT_NAME ${name})
  target_link_libraries(quadtune_${name}
    PUBLIC ${ARG_PUBLIC_DEPS} quadtune::sanitizers
    PRIVATE ${ARG_PRIVATE_DEPS} quadtune::warnings)
  install(TARGETS quadtune_${name} EXPORT quadtuneTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(DIRECTORY include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endfunction()
