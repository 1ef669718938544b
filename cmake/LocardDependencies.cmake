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
if(LOCARD_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(LOCARD_BUILD_BENCHMARKS)
  find_package(benchmark REQUIRED)
endif()
