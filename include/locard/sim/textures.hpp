#pragma once
// Procedural textures and the view-independent shading of the simulated colour camera.
// Textures multiply the base albedo, so a red checker bed stays red with darker squares.

#include <locard/sim/scene_mesh.hpp>

#include <Eigen/Core>

namespace locard::sim {

// Albedo factor at world point `p`: 1 for Plain; 1 or 0.6 for Checker (cells of `scale`
// metres, offset by the seed so that box faces never sit on a cell border); 0.7..1.25 for
// Noise (three octaves of value noise: blotches of 4x `scale`, finest grain `scale`).
double texture_factor(const SurfaceMaterial& material, const Eigen::Vector3d& p);

// Brightness of a surface with unit normal `n` under a fixed ceiling light and ambient light.
// Deliberately independent of the viewpoint, so a point has the same colour in every view.
double shading_factor(const Eigen::Vector3d& n);

// Rec. 709 luma of an RGB albedo given in 0..255, scaled to 0..1.
double luminance(const Eigen::Vector3d& rgb);

}  // namespace locard::sim
