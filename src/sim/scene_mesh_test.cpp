// Scene meshes: primitives face the right way (objects outward, the room inward), carry
// colours and normals, and the scene keeps per-triangle parts and materials.
#include <locard/sim/scene_mesh.hpp>

#include <locard/sim/textures.hpp>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <set>

namespace locard::sim {
namespace {

// Sum over triangles of (normal . (centroid - centre)): positive when faces look outward.
double outwardness(const TriangleMesh& mesh, const Eigen::Vector3f& centre) {
  double sum = 0.0;
  for (const auto& tri : mesh.triangles) {
    const Eigen::Vector3f a = mesh.vertices[tri[0]], b = mesh.vertices[tri[1]], c = mesh.vertices[tri[2]];
    const Eigen::Vector3f n = (b - a).cross(c - a).normalized();
    const double s = n.dot((a + b + c) / 3.0f - centre);
    EXPECT_NE(s, 0.0);
    sum += s > 0 ? 1 : -1;
  }
  return sum / static_cast<double>(mesh.triangles.size());
}

TEST(SceneMesh, BoxFacesOutwardRoomInward) {
  const TriangleMesh box = box_mesh({1, 2, 0.5}, {0.4, 0.6, 1.0}, 30.0, {10, 20, 30});
  EXPECT_EQ(box.triangle_count(), 12u);
  EXPECT_EQ(box.vertex_count(), 24u);
  EXPECT_EQ(outwardness(box, {1, 2, 0.5}), 1.0);
  ASSERT_EQ(box.vertex_colors.size(), box.vertices.size());
  EXPECT_EQ(box.vertex_colors[5], (Rgb8{10, 20, 30}));
  // Winding agrees with the stored vertex normals.
  for (const auto& tri : box.triangles) {
    const Eigen::Vector3f n = (box.vertices[tri[1]] - box.vertices[tri[0]])
                                  .cross(box.vertices[tri[2]] - box.vertices[tri[0]]).normalized();
    EXPECT_GT(n.dot(box.vertex_normals[tri[0]]), 0.999f);
  }
  // Extents after a yaw of 30 degrees: the corners lie at the rotated half sizes.
  float max_z = -1;
  for (const auto& v : box.vertices) max_z = std::max(max_z, v.z());
  EXPECT_FLOAT_EQ(max_z, 1.0f);
  const TriangleMesh room = box_mesh({0, 0, 1.3}, {3.84, 4.0, 2.6}, 0.0, {1, 1, 1}, true);
  EXPECT_EQ(outwardness(room, {0, 0, 1.3}), -1.0);
}

TEST(SceneMesh, CylinderClosedAndOutward) {
  const TriangleMesh c = cylinder_mesh({0, 0, 1}, 0.2, 0.5, 24, {1, 2, 3});
  EXPECT_EQ(c.triangle_count(), 24u * 4);
  EXPECT_EQ(outwardness(c, {0, 0, 1}), 1.0);
  for (const auto& v : c.vertices) {
    EXPECT_LE(std::hypot(v.x(), v.y()), 0.2f + 1e-6f);
    EXPECT_GE(v.z(), 0.75f - 1e-6f);
    EXPECT_LE(v.z(), 1.25f + 1e-6f);
  }
}

TEST(SceneMesh, BedroomPartsMaterialsAndColours) {
  const Scene scene = builtin_scene("bedroom");
  const SceneMesh m = build_scene_mesh(scene);
  ASSERT_EQ(m.part_names.size(), scene.objects.size() + 1);
  EXPECT_EQ(m.part_names[0], "room");
  EXPECT_EQ(m.part_names[1], "bed");
  EXPECT_EQ(m.triangle_part.size(), m.mesh.triangle_count());
  EXPECT_EQ(m.triangle_material.size(), m.mesh.triangle_count());
  EXPECT_EQ(m.triangle_normals.size(), m.mesh.triangle_count());
  EXPECT_EQ(m.mesh.vertex_colors.size(), m.mesh.vertex_count());
  EXPECT_EQ(m.mesh.vertex_normals.size(), m.mesh.vertex_count());
  // Floor vertices carry the floor colour and face up; the ceiling's face down.
  int floor = 0, ceiling = 0;
  for (std::size_t t = 0; t < m.mesh.triangle_count(); ++t) {
    if (m.triangle_part[t] != 0) continue;
    const Rgb8 c = m.mesh.vertex_colors[m.mesh.triangles[t][0]];
    if (m.triangle_normals[t].z() > 0.5f) {
      EXPECT_EQ(c, scene.room.floor_color);
      ++floor;
    } else if (m.triangle_normals[t].z() < -0.5f) {
      EXPECT_EQ(c, scene.room.ceiling_color);
      ++ceiling;
    } else {
      EXPECT_EQ(c, scene.room.wall_color);
    }
  }
  EXPECT_EQ(floor, 2);
  EXPECT_EQ(ceiling, 2);
  // Texture seeds differ per part, and do not depend on the scanner seed.
  std::set<std::uint64_t> seeds;
  for (const auto& mat : m.materials) seeds.insert(mat.seed);
  EXPECT_EQ(seeds.size(), m.materials.size());
  Scene reseeded = scene;
  reseeded.scanner.seed = 1234;
  EXPECT_EQ(build_scene_mesh(reseeded).materials[3].seed, m.materials[3].seed);
}

TEST(Textures, CheckerAlternatesAndNoiseStaysInRange) {
  SurfaceMaterial checker{Texture::Checker, 0.1, 77};
  int dark = 0, light = 0;
  for (int i = 0; i < 100; ++i) {
    const double f = texture_factor(checker, {0.0123 + 0.05 * i, 0.3, 0.0});
    EXPECT_TRUE(f == 1.0 || f == 0.6);
    (f == 1.0 ? light : dark)++;
  }
  EXPECT_NEAR(light, 50, 3);
  // Neighbouring cells along one axis alternate.
  EXPECT_NE(texture_factor(checker, {0.0, 0.0, 0.0}), texture_factor(checker, {0.1, 0.0, 0.0}));
  SurfaceMaterial noise{Texture::Noise, 0.05, 3};
  double lo = 2, hi = 0;
  for (int i = 0; i < 2000; ++i) {
    const double f = texture_factor(noise, {0.013 * i, 0.007 * i, 1.0});
    lo = std::min(lo, f);
    hi = std::max(hi, f);
  }
  EXPECT_GE(lo, 0.7);
  EXPECT_LE(hi, 1.25);
  EXPECT_GT(hi - lo, 0.2);  // real contrast for keypoints
  EXPECT_EQ(texture_factor({Texture::Plain, 0.05, 0}, {1, 2, 3}), 1.0);
  // Seeded: same seed, same pattern; another seed, another one.
  SurfaceMaterial other = noise;
  other.seed = 4;
  EXPECT_EQ(texture_factor(noise, {0.3, 0.2, 0.1}), texture_factor(noise, {0.3, 0.2, 0.1}));
  EXPECT_NE(texture_factor(noise, {0.3, 0.2, 0.1}), texture_factor(other, {0.3, 0.2, 0.1}));
}

}  // namespace
}  // namespace locard::sim
