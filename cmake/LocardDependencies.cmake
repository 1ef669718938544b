# Every dependency comes from Debian packages (scripts/setup.sh installs them).
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(TBB REQUIRED)
find_package(nanoflann REQUIRED)
find_package(PNG REQUIRED)
find_package(JPEG REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(fmt REQUIRED)
find_package(embree 3 REQUIRED)
find_package(CLI11 REQUIRED)
find_package(Ceres 2 REQUIRED)        # pose-graph optimisation
find_package(assimp 5 REQUIRED)       # OBJ/FBX/glTF export and re-import
find_package(CGAL 5 REQUIRED)         # Delaunay/advancing-front triangulation, hole filling
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
