# Compile options shared by every quadtune target, kept in interface targets (no global flags).

add_library(quadtune_warnings INTERFACE)
add_library(quadtune::warnings ALIAS quadtune_warnings)
target_compile_options(quadtune_warnings INTERFACE
  $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
    -Wold-style-cast -Wcast-align -Woverloaded-virtual -Wnull-dereference -Wdouble-promotion
    -Wformat=2 -Wimplicit-fallthrough>)

add_library(quadtune_sanitizers INTERFACE)
add_library(quadtune::sanitizers ALIAS quadtune_sanitizers)
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
# <module>/include/quadtune/<NAME>/.
function(quadtune_add_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(quadtune_${name} ${ARG_SOURCES})
  add_library(quadtune::${name} ALIAS quadtune_${name})
  target_include_directories(quadtune_${name} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>)
  target_compile_features(quadtune_${name} PUBLIC cxx_std_20)
  set_target_properties(quadtune_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  target_link_libraries(quadtune_${name}
    PUBLIC ${ARG_PUBLIC_DEPS} quadtune::sanitizers
    PRIVATE ${ARG_PRIVATE_DEPS} quadtune::warnings)
endfunction()
