#include <locard/sim/view_renderer.hpp>

#include <locard/sim/counter_rng.hpp>
#include <locard/sim/textures.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace locard::sim {
namespace {

// acos on [0, 1] to 2e-8 rad (Abramowitz & Stegun 4.4.46): the incidence angle is needed at
// every pixel and libm's acos was a tenth of the rendering time.
double fast_acos(double x) {
  const double p =
      1.5707963050 +
      x * (-0.2145988016 +
           x * (0.0889789874 +
                x * (-0.0501743046 +
                     x * (0.0308918810 + x * (-0.0170881256 + x * (0.0066700901 + x * -0.0012624911))))));
  return std::sqrt(1.0 - x) * p;
}

}  // namespace

Eigen::Vector3d pixel_ray(const CameraIntrinsics& K, const Isometry3d& T_world_camera, double u,
                          double v) {
  const Eigen::Vector3d d_camera((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
  return T_world_camera.linear() * d_camera;
}

ViewRenderer::ViewRenderer(SceneMesh mesh) : mesh_(std::move(mesh)), raycaster_(mesh_.mesh) {}

SurfaceSample ViewRenderer::sample(const RayHit& hit, const Eigen::Vector3d& origin,
                                   const Eigen::Vector3d& direction) const {
  SurfaceSample s;
  const auto& tri = mesh_.mesh.triangles[hit.triangle];
  s.point = origin + static_cast<double>(hit.t) * direction;
  s.normal = mesh_.triangle_normals[hit.triangle].cast<double>();
  s.part = mesh_.triangle_part[hit.triangle];
  const double b1 = hit.u, b2 = hit.v, b0 = 1.0 - b1 - b2;
  const auto& colors = mesh_.mesh.vertex_colors;
  auto rgb = [&](std::uint32_t i) {
    return Eigen::Vector3d(colors[i].r, colors[i].g, colors[i].b);
  };
  const Eigen::Vector3d base = b0 * rgb(tri[0]) + b1 * rgb(tri[1]) + b2 * rgb(tri[2]);
  const double factor = texture_factor(mesh_.materials[mesh_.triangle_material[hit.triangle]], s.point);
  s.albedo = (base * factor).cwiseMax(0.0).cwiseMin(255.0);
  return s;
}

Eigen::Vector3d ViewRenderer::shaded_color(const SurfaceSample& s) const {
  return s.albedo * shading_factor(s.normal);
}

IdealDepth ViewRenderer::ideal_depth(const KinectModel& model, const Isometry3d& T_world_camera,
                                     std::uint64_t seed, std::uint64_t view) const {
  return trace(model, T_world_camera, seed, view, nullptr);
}

// Two passes over the depth pixels. The first casts each pixel's nominal ray: registered
// colour, ideal depth, incidence and albedo. The second, only with lateral noise, moves each ray
// by a seeded sub-pixel offset. Where the pixel and its 8 neighbours all hit one triangle, the
// moved ray (less than a pixel away) meets that triangle's plane, which is solved directly;
// elsewhere, near edges and silhouettes where lateral noise matters, the ray is cast again.
IdealDepth ViewRenderer::trace(const KinectModel& model, const Isometry3d& T_world_camera,
                               std::uint64_t seed, std::uint64_t view, ColorImage* color) const {
  const CameraIntrinsics& K = model.intrinsics;
  const int w = K.width, h = K.height;
  IdealDepth ideal(w, h);
  if (color) *color = ColorImage(w, h, 0);
  const Eigen::Vector3d origin = T_world_camera.translation();
  const Eigen::Vector3f origin_f = origin.cast<float>();
  std::vector<std::uint32_t> triangle(ideal.z.size(), RayHit::kNoTriangle);

  auto set_geometry = [&](std::size_t i, double z, const Eigen::Vector3d& normal,
                          const Eigen::Vector3d& direction) {
    const double cos_incidence = std::min(1.0, std::abs(normal.dot(direction)) / direction.norm());
    ideal.z[i] = static_cast<float>(z);
    ideal.incidence[i] = static_cast<float>(fast_acos(cos_incidence));
  };

  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    std::vector<Eigen::Vector3f> directions(static_cast<std::size_t>(w));
    std::vector<RayHit> hits(static_cast<std::size_t>(w));
    for (int v = rows.begin(); v < rows.end(); ++v) {
      for (int u = 0; u < w; ++u) directions[u] = pixel_ray(K, T_world_camera, u, v).cast<float>();
      raycaster_.intersect_coherent(origin_f, directions.data(), directions.size(), hits.data());
      for (int u = 0; u < w; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * w + u;
        const RayHit& hit = hits[u];
        if (!hit.hit()) continue;
        const Eigen::Vector3d direction = directions[u].cast<double>();
        const SurfaceSample s = sample(hit, origin, direction);
        if (color) write_color(*color, u, v, shaded_color(s), model, seed, view);
        triangle[i] = hit.triangle;
        set_geometry(i, hit.t, s.normal, direction);
        ideal.luminance[i] = static_cast<float>(luminance(s.albedo));
      }
    }
  });
  if (!model.lateral_noise()) return ideal;

  const std::vector<float> nominal_z = ideal.z;
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int v = rows.begin(); v < rows.end(); ++v) {
      for (int u = 0; u < w; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * w + u;
        if (triangle[i] == RayHit::kNoTriangle) continue;
        CounterRng rng(seed, RngStream::LateralNoise, view, i);
        const double sigma_px = model.lateral_sigma_px(nominal_z[i], ideal.incidence[i]);
        const auto [nu, nv] = rng.normal_pair();
        const double du = sigma_px * nu, dv = sigma_px * nv;
        const Eigen::Vector3d direction = pixel_ray(K, T_world_camera, u + du, v + dv);
        bool flat = std::abs(du) < 1.0 && std::abs(dv) < 1.0 && u > 0 && v > 0 && u + 1 < w &&
                    v + 1 < h;
        for (int dy = -1; flat && dy <= 1; ++dy)
          for (int dx = -1; flat && dx <= 1; ++dx)
            flat = triangle[i + static_cast<std::ptrdiff_t>(dy) * w + dx] == triangle[i];
        if (flat) {
          const Eigen::Vector3d n = mesh_.triangle_normals[triangle[i]].cast<double>();
          const Eigen::Vector3d d0 = pixel_ray(K, T_world_camera, u, v);
          // Plane through the nominal hit: n . (o + t d - o - z0 d0) = 0.
          const double t = nominal_z[i] * n.dot(d0) / n.dot(direction);
          set_geometry(i, t, n, direction);
          continue;
        }
        const RayHit hit = raycaster_.intersect(origin_f, direction.cast<float>());
        if (!hit.hit()) {
          ideal.z[i] = 0.0f;
          continue;
        }
        const SurfaceSample s = sample(hit, origin, direction);
        set_geometry(i, hit.t, s.normal, direction);
        ideal.luminance[i] = static_cast<float>(luminance(s.albedo));
      }
    }
  });
  return ideal;
}

void ViewRenderer::write_color(ColorImage& image, int u, int v, Eigen::Vector3d rgb,
                               const KinectModel& model, std::uint64_t seed,
                               std::uint64_t view) const {
  if (model.color_noise_sigma > 0.0) {
    // Keyed by the image width too: HD and depth-resolution images draw different noise.
    CounterRng rng(seed, RngStream::ColorNoise, view ^ (static_cast<std::uint64_t>(image.width()) << 32),
                   static_cast<std::uint64_t>(v) * image.width() + u);
    rgb += model.color_noise_sigma *
           Eigen::Vector3d(rng.approx_normal(), rng.approx_normal(), rng.approx_normal());
  }
  // Clamped first, so adding 0.5 and truncating rounds to nearest.
  for (int c = 0; c < 3; ++c)
    image.at(u, v, c) = static_cast<std::uint8_t>(std::clamp(rgb[c], 0.0, 255.0) + 0.5);
}

ColorImage ViewRenderer::color_image(const KinectModel& model, const CameraIntrinsics& K,
                                     const Isometry3d& T_world_camera, std::uint64_t seed,
                                     std::uint64_t view) const {
  ColorImage image(K.width, K.height, 0);
  const Eigen::Vector3d origin = T_world_camera.translation();
  const Eigen::Vector3f origin_f = origin.cast<float>();
  tbb::parallel_for(tbb::blocked_range<int>(0, K.height), [&](const tbb::blocked_range<int>& rows) {
    std::vector<Eigen::Vector3f> directions(static_cast<std::size_t>(K.width));
    std::vector<RayHit> hits(static_cast<std::size_t>(K.width));
    for (int v = rows.begin(); v < rows.end(); ++v) {
      for (int u = 0; u < K.width; ++u)
        directions[u] = pixel_ray(K, T_world_camera, u, v).cast<float>();
      raycaster_.intersect_coherent(origin_f, directions.data(), directions.size(), hits.data());
      for (int u = 0; u < K.width; ++u) {
        if (!hits[u].hit()) continue;
        const SurfaceSample s = sample(hits[u], origin, directions[u].cast<double>());
        write_color(image, u, v, shaded_color(s), model, seed, view);
      }
    }
  });
  return image;
}

SensorFrame ViewRenderer::render(const KinectModel& model, const Isometry3d& T_world_camera,
                                 std::uint64_t seed, std::uint64_t view, bool color_hd) const {
  SensorFrame frame;
  frame.depth = model.measure(trace(model, T_world_camera, seed, view, &frame.color), seed, view);
  if (color_hd)
    frame.color_hd = color_image(model, model.color_hd_intrinsics, T_world_camera, seed, view);
  return frame;
}

}  // namespace locard::sim
