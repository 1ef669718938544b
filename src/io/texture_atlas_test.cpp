// The texture atlas against an independent oracle: bilinear sampling of the baked image (as a
// GPU does) at random points of every triangle must give the barycentric interpolation of the
// triangle's vertex colours - no bleeding from the neighbour sharing its cell, no seams.
#include "texture_atlas.hpp"

#include <locard/core/error.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace locard::detail {
namespace {

Eigen::Vector3f bilinear(const ColorImage& image, const Eigen::Vector2f& uv) {
  const float x = uv.x() * image.width() - 0.5f, y = (1.f - uv.y()) * image.height() - 0.5f;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float fx = x - x0, fy = y - y0;
  auto px = [&](int xi, int yi) {
    xi = std::clamp(xi, 0, image.width() - 1);
    yi = std::clamp(yi, 0, image.height() - 1);
    const std::uint8_t* p = image.row(yi) + 3 * xi;
    return Eigen::Vector3f(p[0], p[1], p[2]);
  };
  return (1 - fx) * (1 - fy) * px(x0, y0) + fx * (1 - fy) * px(x0 + 1, y0) +
         (1 - fx) * fy * px(x0, y0 + 1) + fx * fy * px(x0 + 1, y0 + 1);
}

// Random triangles whose vertex colours differ by up to 64 steps per channel around a random
// base (a scan's colours vary less than that over one triangle), kept where the linear
// extension half a leg beyond the triangle stays within 0..255 (texture_atlas.hpp).
TriangleMesh random_mesh(std::size_t triangles, std::vector<Rgb8>& colors, std::mt19937& rng,
                         int spread) {
  std::uniform_int_distribution<int> base(2 * spread, 255 - 2 * spread), off(-spread, spread);
  TriangleMesh mesh;
  for (std::uint32_t t = 0; t < triangles; ++t) {
    const int b[3] = {base(rng), base(rng), base(rng)};
    for (int k = 0; k < 3; ++k) {
      mesh.vertices.emplace_back(static_cast<float>(t), static_cast<float>(k), 0.f);
      colors.push_back({static_cast<std::uint8_t>(b[0] + off(rng)),
                        static_cast<std::uint8_t>(b[1] + off(rng)),
                        static_cast<std::uint8_t>(b[2] + off(rng))});
    }
    mesh.triangles.push_back({3 * t, 3 * t + 1, 3 * t + 2});
  }
  return mesh;
}

// Largest difference between bilinear samples and interpolated vertex colours at `samples`
// points of every triangle: the corners and centroid first, then uniform random points.
float worst_sample_error(const TriangleMesh& mesh, const std::vector<Rgb8>& colors,
                         const TextureAtlas& atlas, int samples, std::mt19937& rng) {
  std::uniform_real_distribution<float> unit(0.f, 1.f);
  float worst = 0.f;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int sample = 0; sample < samples; ++sample) {
      float a = unit(rng), b = unit(rng);
      if (a + b > 1.f) a = 1.f - a, b = 1.f - b;
      if (sample < 3) a = sample == 1, b = sample == 2;  // the corners exactly
      if (sample == 3) a = b = 1.f / 3.f;                // the centroid
      const float w[3] = {1.f - a - b, a, b};
      Eigen::Vector2f uv = Eigen::Vector2f::Zero();
      Eigen::Vector3f want = Eigen::Vector3f::Zero();
      for (int k = 0; k < 3; ++k) {
        uv += w[k] * atlas.uv[t][k];
        const Rgb8 c = colors[mesh.triangles[t][k]];
        want += w[k] * Eigen::Vector3f(c.r, c.g, c.b);
      }
      worst = std::max(worst, (bilinear(atlas.image, uv) - want).cwiseAbs().maxCoeff());
    }
  return worst;
}

class TextureAtlasSizes : public ::testing::TestWithParam<std::size_t> {};

TEST_P(TextureAtlasSizes, BilinearSamplesEqualInterpolatedVertexColours) {
  std::mt19937 rng(7);
  std::vector<Rgb8> colors;
  const TriangleMesh mesh = random_mesh(GetParam(), colors, rng, 32);
  const TextureAtlas atlas = bake_texture_atlas(mesh, colors);
  ASSERT_EQ(atlas.uv.size(), mesh.triangles.size());
  EXPECT_EQ(atlas.image.width() % TextureAtlas::kCell, 0);
  // 8-bit rounding of each texel: half a step.
  EXPECT_LE(worst_sample_error(mesh, colors, atlas, 50, rng), 0.51f) << GetParam() << " triangles";
}

// Any colours at all (0..255, unrelated): corners and centroid read only texels inside the
// triangle, so they stay exact even where the extension beyond it is clamped.
TEST_P(TextureAtlasSizes, CornersAndCentroidExactForAnyColours) {
  std::mt19937 rng(11);
  std::vector<Rgb8> colors;
  TriangleMesh mesh = random_mesh(GetParam(), colors, rng, 0);
  std::uniform_int_distribution<int> byte(0, 255);
  for (Rgb8& c : colors)
    c = {static_cast<std::uint8_t>(byte(rng)), static_cast<std::uint8_t>(byte(rng)),
         static_cast<std::uint8_t>(byte(rng))};
  const TextureAtlas atlas = bake_texture_atlas(mesh, colors);
  EXPECT_LE(worst_sample_error(mesh, colors, atlas, 4, rng), 0.51f) << GetParam() << " triangles";
}

INSTANTIATE_TEST_SUITE_P(Counts, TextureAtlasSizes, ::testing::Values(1u, 2u, 7u, 1000u));

TEST(TextureAtlas, EmptyMeshGivesOneCell) {
  const TextureAtlas atlas = bake_texture_atlas(TriangleMesh{}, {});
  EXPECT_EQ(atlas.image.width(), TextureAtlas::kCell);
  EXPECT_TRUE(atlas.uv.empty());
}

}  // namespace
}  // namespace locard::detail
