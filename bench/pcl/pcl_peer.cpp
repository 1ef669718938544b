// PCL peer for Locard's benchmarks: times a PCL operation on a PLY cloud and prints JSON.
//
//   locard_pcl_peer voxel CLOUD.ply VOXEL_SIZE REPEATS
//       pcl::VoxelGrid<pcl::PointXYZRGB> (centroid per voxel, colours averaged), best of REPEATS.
//   locard_pcl_peer features CLOUD.ply NORMAL_RADIUS NORMAL_MAX_NN FPFH_RADIUS REPEATS
//       pcl::NormalEstimationOMP + pcl::FPFHEstimationOMP (radius search), best of REPEATS.

#include <pcl/features/fpfh_omp.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/common/io.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include "ply_reader.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <limits>
#include <string>

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Process CPU time (all threads), seconds.
double cpu_seconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

int voxel(const char* path, float leaf, int repeats) {
  pcl::PointCloud<pcl::PointXYZRGB>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZRGB>);
  locard_pcl::read_ply(path, *cloud);
  double best = std::numeric_limits<double>::infinity();
  double best_cpu = std::numeric_limits<double>::infinity();
  std::size_t out_points = 0;
  for (int r = 0; r < repeats; ++r) {
    pcl::PointCloud<pcl::PointXYZRGB> down;
    const double cpu_start = cpu_seconds();
    const auto start = std::chrono::steady_clock::now();
    pcl::VoxelGrid<pcl::PointXYZRGB> grid;
    grid.setInputCloud(cloud);
    grid.setLeafSize(leaf, leaf, leaf);
    grid.filter(down);
    best = std::min(best, seconds_since(start));
    best_cpu = std::min(best_cpu, cpu_seconds() - cpu_start);
    out_points = down.size();
  }
  std::printf("{\"peer\": \"pcl %s\", \"points\": %zu, \"output_points\": %zu, \"seconds\": %.9f, "
              "\"cpu_seconds\": %.9f}\n",
              PCL_VERSION_PRETTY, cloud->size(), out_points, best, best_cpu);
  return 0;
}

int features(const char* path, float normal_radius, int normal_max_nn, float fpfh_radius,
             int repeats) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  locard_pcl::read_ply(path, *cloud);
  double best = std::numeric_limits<double>::infinity();
  double best_cpu = std::numeric_limits<double>::infinity();
  for (int r = 0; r < repeats; ++r) {
    const double cpu_start = cpu_seconds();
    const auto start = std::chrono::steady_clock::now();
    pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
    pcl::PointCloud<pcl::Normal>::Ptr normals(new pcl::PointCloud<pcl::Normal>);
    pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne;
    ne.setInputCloud(cloud);
    ne.setSearchMethod(tree);
    ne.setRadiusSearch(normal_radius);
    ne.setViewPoint(0.f, 0.f, 0.f);
    ne.compute(*normals);
    pcl::PointCloud<pcl::FPFHSignature33> descriptors;
    pcl::FPFHEstimationOMP<pcl::PointXYZ, pcl::Normal, pcl::FPFHSignature33> fpfh;
    fpfh.setInputCloud(cloud);
    fpfh.setInputNormals(normals);
    fpfh.setSearchMethod(tree);
    fpfh.setRadiusSearch(fpfh_radius);
    fpfh.compute(descriptors);
    best = std::min(best, seconds_since(start));
    best_cpu = std::min(best_cpu, cpu_seconds() - cpu_start);
  }
  (void)normal_max_nn;  // PCL's radius search has no neighbour cap
  std::printf("{\"peer\": \"pcl %s\", \"points\": %zu, \"seconds\": %.9f, \"cpu_seconds\": %.9f}\n",
              PCL_VERSION_PRETTY, cloud->size(), best, best_cpu);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "";
  if (mode == "voxel" && argc == 5) {
    return voxel(argv[2], std::strtof(argv[3], nullptr), std::atoi(argv[4]));
  }
  if (mode == "features" && argc == 7) {
    return features(argv[2], std::strtof(argv[3], nullptr), std::atoi(argv[4]),
                    std::strtof(argv[5], nullptr), std::atoi(argv[6]));
  }
  std::fprintf(stderr, "usage: %s voxel CLOUD.ply VOXEL REPEATS | features CLOUD.ply "
                       "NORMAL_RADIUS NORMAL_MAX_NN FPFH_RADIUS REPEATS\n", argv[0]);
  return 2;
}
