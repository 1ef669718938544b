// Texture atlas of per-triangle patches; the layout and why it does not bleed are in
// texture_atlas.hpp.
#include "texture_atlas.hpp"

#include <locard/core/error.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace locard::detail {
namespace {

constexpr int kCell = TextureAtlas::kCell;

// A triangle's colour as a linear function of its patch coordinates (s, t).
struct LinearColor {
  Eigen::Vector3f c0, ds, dt;
  Eigen::Vector3f at(float s, float t) const { return c0 + ds * s + dt * t; }
};

LinearColor linear_color(const std::array<std::uint32_t, 3>& tri, const std::vector<Rgb8>& colors) {
  auto v = [&](int k) {
    const Rgb8 c = colors[tri[k]];
    return Eigen::Vector3f(c.r, c.g, c.b);
  };
  return {v(0), v(1) - v(0), v(2) - v(0)};
}

// Patch coordinates of pixel (i, j) of a cell: lower patch from corner (0,0), upper from (4,4);
// the legs are 2 pixels long.
float lower_s(int i) { return 0.5f * static_cast<float>(i); }
float upper_s(int i) { return 0.5f * static_cast<float>(kCell - 1 - i); }

void put(ColorImage& image, int x, int y, const Eigen::Vector3f& c) {
  std::uint8_t* p = image.row(y) + 3 * x;
  for (int k = 0; k < 3; ++k)
    p[k] = static_cast<std::uint8_t>(std::lround(std::clamp(c[k], 0.f, 255.f)));
}

// Fills one cell with its lower triangle's colours and, when there is one, its upper's.
void fill_cell(ColorImage& image, int x0, int y0, const LinearColor& lower,
               const LinearColor* upper) {
  for (int j = 0; j < kCell; ++j)
    for (int i = 0; i < kCell; ++i) {
      const Eigen::Vector3f l = lower.at(lower_s(i), lower_s(j));
      Eigen::Vector3f c = l;
      if (upper && i + j >= kCell - 1) {
        const Eigen::Vector3f u = upper->at(upper_s(i), upper_s(j));
        c = i + j == kCell - 1 ? Eigen::Vector3f(0.5f * (l + u)) : u;
      }
      put(image, x0 + i, y0 + j, c);
    }
}

}  // namespace

TextureAtlas bake_texture_atlas(const TriangleMesh& mesh, const std::vector<Rgb8>& colors) {
  const std::size_t triangles = mesh.triangles.size();
  const std::size_t cells = std::max<std::size_t>(1, (triangles + 1) / 2);
  const auto cols = static_cast<std::size_t>(std::ceil(std::sqrt(static_cast<double>(cells))));
  const std::size_t rows = (cells + cols - 1) / cols;
  if (std::max(cols, rows) * kCell > static_cast<std::size_t>(TextureAtlas::kMaxSide))
    throw Error(fmt::format("{} triangles need a texture wider than {} pixels; decimate the "
                            "mesh (--target-triangles) before exporting OBJ",
                            triangles, TextureAtlas::kMaxSide));
  const int width = static_cast<int>(cols) * kCell;
  const int height = static_cast<int>(rows) * kCell;
  TextureAtlas atlas;
  atlas.image = ColorImage(width, height, std::uint8_t{0});
  atlas.uv.resize(triangles);
  // Texture coordinates of pixel centre (x, y): v counts from the bottom row up.
  auto uv = [&](int x, int y) {
    return Eigen::Vector2f((static_cast<float>(x) + 0.5f) / static_cast<float>(width),
                           1.f - (static_cast<float>(y) + 0.5f) / static_cast<float>(height));
  };
  constexpr int kLeg = 2, kFar = kCell - 1;
  for (std::size_t cell = 0; cell < cells && 2 * cell < triangles; ++cell) {
    const int x0 = static_cast<int>(cell % cols) * kCell;
    const int y0 = static_cast<int>(cell / cols) * kCell;
    const std::size_t t = 2 * cell;
    const LinearColor lower = linear_color(mesh.triangles[t], colors);
    atlas.uv[t] = {uv(x0, y0), uv(x0 + kLeg, y0), uv(x0, y0 + kLeg)};
    if (t + 1 < triangles) {
      const LinearColor upper = linear_color(mesh.triangles[t + 1], colors);
      atlas.uv[t + 1] = {uv(x0 + kFar, y0 + kFar), uv(x0 + kFar - kLeg, y0 + kFar),
                         uv(x0 + kFar, y0 + kFar - kLeg)};
      fill_cell(atlas.image, x0, y0, lower, &upper);
    } else {
      fill_cell(atlas.image, x0, y0, lower, nullptr);
    }
  }
  return atlas;
}

}  // namespace locard::detail
