# Every dependency is a Debian 12 package (scripts/setup.sh installs them).
find_package(PkgConfig REQUIRED)
find_package(Threads REQUIRED)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(TBB REQUIRED)
find_package(yaml-cpp REQUIRED)
find_package(CGAL REQUIRED)
find_package(Boost REQUIRED)  # header-only parts (Boost.Random's Sobol' sequence)
find_package(SQLite3 REQUIRED)
find_package(nlohmann_json REQUIRED)
find_package(CLI11 REQUIRED)
find_package(spdlog REQUIRED)
find_package(fmt REQUIRED)
find_package(LAPACK REQUIRED)
# Bullet from Debian is single precision; its pkg-config file carries the right defines.
pkg_check_modules(BULLET REQUIRED IMPORTED_TARGET bullet)
# Ipopt 3.11 ships no CMake config.
pkg_check_modules(IPOPT REQUIRED IMPORTED_TARGET ipopt)
# libLBFGS (Debian: liblbfgs-dev) solves the EGO back end's unconstrained problem.
pkg_check_modules(LBFGS REQUIRED IMPORTED_TARGET liblbfgs)

# MPI (Debian: libopenmpi-dev, openmpi-bin) for distributed experiments. quadtune uses MPI's C
# API only. QUADTUNE_HAVE_MPI says whether it is built in; MPIEXEC_EXECUTABLE runs the MPI tests.
set(QUADTUNE_HAVE_MPI OFF)
if(QUADTUNE_WITH_MPI)
  find_package(MPI COMPONENTS C)
  if(MPI_C_FOUND)
    set(QUADTUNE_HAVE_MPI ON)
  else()
    message(STATUS "MPI not found: building without distributed experiments")
  endif()
endif()

# mimalloc (Debian: libmimalloc-dev) replaces malloc/free in quadtune's programs: Ipopt allocates
# and frees its small vectors many times per iteration, and the solver is the hot path
# (measured: +15% short-term evaluations per second). quadtune::allocator is linked into every
# executable; without mimalloc it is empty and the C library's allocator is used.
add_library(quadtune_allocator INTERFACE)
add_library(quadtune::allocator ALIAS quadtune_allocator)
if(QUADTUNE_WITH_MIMALLOC)
  find_package(mimalloc CONFIG)
  if(TARGET mimalloc)
    target_link_libraries(quadtune_allocator INTERFACE mimalloc)
    message(STATUS "quadtune: malloc from mimalloc ${mimalloc_VERSION}")
  else()
    message(STATUS "mimalloc not found: the C library's malloc is used")
  endif()
endif()

if(TARGET yaml-cpp AND NOT TARGET yaml-cpp::yaml-cpp)
  add_library(yaml-cpp::yaml-cpp ALIAS yaml-cpp)
endif()
