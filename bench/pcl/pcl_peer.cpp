// PCL peer for Locard's filter and feature benchmarks (protocol: peer_protocol.hpp). The cloud
// is the binary PLY file the benchmark wrote (read by ply_reader.hpp outside the clock).
//
//  voxel_down_sample  inputs.cloud (with colour), parameters.voxel. Timed:
//                     pcl::VoxelGrid<pcl::PointXYZRGB> (centroid per voxel, colours averaged).
//                     Output {"points", "voxels"}. VoxelGrid is single-threaded.
//  normals_fpfh       inputs.cloud, parameters.normal_radius, normal_max_nn, fpfh_radius,
//                     fpfh_max_nn. Timed: kd-tree, pcl::NormalEstimationOMP (radius search,
//                     oriented towards the origin) and pcl::FPFHEstimationOMP (radius search)
//                     with the workload's thread count. PCL's radius searches have no
//                     neighbour cap, so normal_max_nn and fpfh_max_nn cannot be applied; the
//                     output says so ("neighbour_caps_applied": false). Output {"points",
//                     "descriptors"}.

#include "peer_protocol.hpp"
#include "ply_reader.hpp"

#include <pcl/features/fpfh_omp.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

namespace {

using nlohmann::json;

locard_pcl::Pass prepare_voxel(const json& task) {
  pcl::PointCloud<pcl::PointXYZRGB>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZRGB>);
  locard_pcl::read_ply(task.at("inputs").at("cloud").get<std::string>(), *cloud);
  const auto leaf = task.at("parameters").at("voxel").get<float>();
  return [cloud, leaf] {
    pcl::PointCloud<pcl::PointXYZRGB> down;
    pcl::VoxelGrid<pcl::PointXYZRGB> grid;
    grid.setInputCloud(cloud);
    grid.setLeafSize(leaf, leaf, leaf);
    grid.filter(down);
    return json{{"points", cloud->size()}, {"voxels", down.size()}};
  };
}

locard_pcl::Pass prepare_normals_fpfh(const json& task) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  locard_pcl::read_ply(task.at("inputs").at("cloud").get<std::string>(), *cloud);
  const json& p = task.at("parameters");
  const auto normal_radius = p.at("normal_radius").get<double>();
  const auto fpfh_radius = p.at("fpfh_radius").get<double>();
  const auto threads = static_cast<unsigned>(task.value("threads", 0));  // 0: PCL's automatic
  return [cloud, normal_radius, fpfh_radius, threads] {
    pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
    pcl::PointCloud<pcl::Normal>::Ptr normals(new pcl::PointCloud<pcl::Normal>);
    pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne(threads);
    ne.setInputCloud(cloud);
    ne.setSearchMethod(tree);
    ne.setRadiusSearch(normal_radius);
    ne.setViewPoint(0.f, 0.f, 0.f);
    ne.compute(*normals);
    pcl::PointCloud<pcl::FPFHSignature33> descriptors;
    pcl::FPFHEstimationOMP<pcl::PointXYZ, pcl::Normal, pcl::FPFHSignature33> fpfh(threads);
    fpfh.setInputCloud(cloud);
    fpfh.setInputNormals(normals);
    fpfh.setSearchMethod(tree);
    fpfh.setRadiusSearch(fpfh_radius);
    fpfh.compute(descriptors);
    return json{{"points", cloud->size()},
                {"descriptors", descriptors.size()},
                {"neighbour_caps_applied", false}};
  };
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return locard_pcl::serve(argc, argv, "pcl " PCL_VERSION_PRETTY,
                             {{"voxel_down_sample", prepare_voxel},
                              {"normals_fpfh", prepare_normals_fpfh}});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "locard_pcl_peer: %s\n", e.what());
    return 1;
  }
}
