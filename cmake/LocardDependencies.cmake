# Every dependency comes from Debian packages (scripts/setup.sh installs them).
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(TBB REQUIRED)
find_package(nanoflann REQUIRED)
find_package(PNG REQUIRED)
find_package(JPEG REQUIRED)
# libdeflate: the PNG fast path's inflate (no CMake package in Debian 12, so by name).
find_path(LIBDEFLATE_INCLUDE_DIR libdeflate.h REQUIRED)
find_library(LIBDEFLATE_LIBRARY NAMES deflate REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(fmt REQUIRED)
find_package(embree 3 REQUIRED)
find_package(CLI11 REQUIRED)
find_package(Ceres 2 REQUIRED)        # pose-graph optimisation
find_package(assimp 5 REQUIRED)       # OBJ/FBX/glTF export and re-import
find_package(CGAL 5 REQUIRED)         # Delaunay/advancing-front triangulation, hole filling
find_package(OpenSSL REQUIRED)        # SHA-256 of case inputs and outputs (forensics)
find_package(pugixml REQUIRED)        # the XML section of E57 files (src/io/e57_*.cpp)
# Bullet rigid-body physics for `locard simulate`, the double-precision build Debian ships
# beside the float one. Its config file gives paths relative to BULLET_ROOT_DIR and bare
# library names, so absolute ones are made here (LOCARD_BULLET_*), linked PRIVATE by the library.
find_package(Bullet REQUIRED CONFIGS BulletConfig-float64.cmake)
set(LOCARD_BULLET_INCLUDE_DIRS)
foreach(dir IN LISTS BULLET_INCLUDE_DIRS)
  cmake_path(ABSOLUTE_PATH dir BASE_DIRECTORY "${BULLET_ROOT_DIR}")
  list(APPEND LOCARD_BULLET_INCLUDE_DIRS "${dir}")
endforeach()
set(LOCARD_BULLET_LIBRARIES)
foreach(lib IN ITEMS BulletDynamics-float64 BulletCollision-float64 LinearMath-float64)
  find_library(LOCARD_BULLET_${lib} NAMES ${lib} REQUIRED
               HINTS "${BULLET_ROOT_DIR}/${BULLET_LIBRARY_DIRS}")
  list(APPEND LOCARD_BULLET_LIBRARIES "${LOCARD_BULLET_${lib}}")
endforeach()
if(LOCARD_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(LOCARD_BUILD_BENCHMARKS)
  find_package(benchmark REQUIRED)
endif()
# The viewer's local HTTP server (src/viewer): Debian's cpp-httplib is a compiled library whose
# header must be read with the macros it was built with (its OpenSSL/zlib/Brotli support changes
# the classes' layout), so flags and library come from its pkg-config file (no CMake package);
# linked by absolute path. The server runs on threads.
find_package(PkgConfig REQUIRED)
pkg_check_modules(LOCARD_HTTPLIB REQUIRED cpp-httplib)
find_package(Threads REQUIRED)
