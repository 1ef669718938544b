// PCL peer for Locard's filter and feature benchmarks (protocol: peer_protocol.hpp). The cloud
// is the binary PLY file the benchmark wrote (read by ply_reader.hpp outside the clock).
//
//  voxel_down_sample  inputs.cloud (with colour), parameters.voxel. Timed:
//                     pcl::VoxelGrid<pcl::PointXYZRGB> (centroid per voxel, colours averaged).
//                     Output {"points", "voxels"}. VoxelGrid is single-threaded.
//  normals            inputs.cloud, parameters.normal_radius, normal_max_nn, viewpoint,
//                     sample_every. Timed: kd-tree and pcl::NormalEstimationOMP (radius
//                     search, oriented towards the viewpoint) with the workload's threads.
//  normals_fpfh       the same, then pcl::FPFHEstimationOMP (parameters.fpfh_radius,
//                     fpfh_max_nn). PCL's radius searches have no neighbour cap, so the
//                     *_max_nn values cannot be applied; the output says so
//                     ("neighbour_caps_applied": false). Output {"points", "normals" and
//                     "fpfh": every sample_every-th point's, flat; "descriptors"}.

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

// Every `every`-th value group of a cloud's normals / descriptors, flat (the features bench
// scores samples against its brute-force oracle and Locard's descriptors).
json sampled_normals(const pcl::PointCloud<pcl::Normal>& normals, std::size_t every) {
  json out = json::array();
  for (std::size_t i = 0; i < normals.size(); i += every)
    for (int k = 0; k < 3; ++k) out.push_back(normals[i].normal[k]);
  return out;
}
json sampled_fpfh(const pcl::PointCloud<pcl::FPFHSignature33>& fpfh, std::size_t every) {
  json out = json::array();
  for (std::size_t i = 0; i < fpfh.size(); i += every)
    for (float v : fpfh[i].histogram) out.push_back(v);
  return out;
}

// The "normals" and "normals_fpfh" kernels: a kd-tree and normals (+ FPFH when `with_fpfh`).
locard_pcl::Pass prepare_features(const json& task, bool with_fpfh) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  locard_pcl::read_ply(task.at("inputs").at("cloud").get<std::string>(), *cloud);
  const json& p = task.at("parameters");
  const auto normal_radius = p.at("normal_radius").get<double>();
  const auto fpfh_radius = with_fpfh ? p.at("fpfh_radius").get<double>() : 0.0;
  const auto viewpoint = p.at("viewpoint").get<std::vector<float>>();
  const auto every = p.at("sample_every").get<std::size_t>();
  const auto threads = static_cast<unsigned>(task.value("threads", 0));  // 0: PCL's automatic
  return [=] {
    pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
    pcl::PointCloud<pcl::Normal>::Ptr normals(new pcl::PointCloud<pcl::Normal>);
    pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne(threads);
    ne.setInputCloud(cloud);
    ne.setSearchMethod(tree);
    ne.setRadiusSearch(normal_radius);
    ne.setViewPoint(viewpoint.at(0), viewpoint.at(1), viewpoint.at(2));
    ne.compute(*normals);
    json out = {{"points", cloud->size()},
                {"normals", sampled_normals(*normals, every)},
                {"neighbour_caps_applied", false}};
    if (!with_fpfh) return out;
    pcl::PointCloud<pcl::FPFHSignature33> descriptors;
    pcl::FPFHEstimationOMP<pcl::PointXYZ, pcl::Normal, pcl::FPFHSignature33> fpfh(threads);
    fpfh.setInputCloud(cloud);
    fpfh.setInputNormals(normals);
    fpfh.setSearchMethod(tree);
    fpfh.setRadiusSearch(fpfh_radius);
    fpfh.compute(descriptors);
    out["descriptors"] = descriptors.size();
    out["fpfh"] = sampled_fpfh(descriptors, every);
    return out;
  };
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return locard_pcl::serve(argc, argv, "pcl " PCL_VERSION_PRETTY,
                             {{"voxel_down_sample", prepare_voxel},
                              {"normals", [](const json& t) { return prepare_features(t, false); }},
                              {"normals_fpfh", [](const json& t) { return prepare_features(t, true); }}});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "locard_pcl_peer: %s\n", e.what());
    return 1;
  }
}
