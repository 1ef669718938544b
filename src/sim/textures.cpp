#include <locard/sim/textures.hpp>

#include <locard/sim/counter_rng.hpp>

#include <algorithm>
#include <array>
#include <cmath>

namespace locard::sim {
namespace {

// Offset in [0.1, 0.9) cells per axis, so faces at round coordinates stay inside a cell.
double seed_offset(std::uint64_t seed, int axis) {
  const double u = static_cast<double>(mix64(seed ^ (0xA5A5ULL + axis)) >> 11) * 0x1.0p-53;
  return 0.1 + 0.8 * u;
}

// Perlin-style lattice hashing through a fixed permutation table: three table lookups per
// lattice point instead of a 64-bit mix, as this runs for every pixel of every view. The
// material seed shifts the lattice, so parts with different seeds get different patterns.
struct NoiseTables {
  std::array<std::uint8_t, 512> perm{};
  std::array<float, 256> value{};
};

constexpr NoiseTables make_noise_tables() {
  NoiseTables t;
  std::array<std::uint8_t, 256> p{};
  for (int i = 0; i < 256; ++i) p[i] = static_cast<std::uint8_t>(i);
  for (int i = 255; i > 0; --i) {  // Fisher-Yates, fixed seed
    const auto j = static_cast<int>(mix64(0x5EEDULL + static_cast<std::uint64_t>(i)) % (i + 1));
    const std::uint8_t tmp = p[i];
    p[i] = p[j];
    p[j] = tmp;
  }
  for (int i = 0; i < 512; ++i) t.perm[i] = p[i & 255];
  for (int i = 0; i < 256; ++i)
    t.value[i] = static_cast<float>(mix64(0xA11CEULL + static_cast<std::uint64_t>(i)) >> 40) * 0x1.0p-24f;
  return t;
}

constexpr NoiseTables kNoise = make_noise_tables();

double smooth(double t) { return t * t * (3.0 - 2.0 * t); }

// Trilinear value noise in [0, 1) at p (in lattice units).
double value_noise(std::uint64_t seed, const Eigen::Vector3d& p) {
  const Eigen::Vector3d cell = p.array().floor();
  const Eigen::Vector3d f = p - cell;
  const std::uint64_t offset = mix64(seed);
  const int x = static_cast<int>((static_cast<std::int64_t>(cell.x()) + static_cast<std::int64_t>(offset & 255)) & 255);
  const int y = static_cast<int>((static_cast<std::int64_t>(cell.y()) + static_cast<std::int64_t>((offset >> 8) & 255)) & 255);
  const int z = static_cast<int>((static_cast<std::int64_t>(cell.z()) + static_cast<std::int64_t>((offset >> 16) & 255)) & 255);
  const auto& P = kNoise.perm;
  const auto& V = kNoise.value;
  const int a = P[x] + y, b = P[x + 1] + y;
  const int aa = P[a] + z, ab = P[a + 1] + z, ba = P[b] + z, bb = P[b + 1] + z;
  const double sx = smooth(f.x()), sy = smooth(f.y()), sz = smooth(f.z());
  auto lerp = [](double lo, double hi, double t) { return lo + (hi - lo) * t; };
  const double z0 = lerp(lerp(V[P[aa]], V[P[ba]], sx), lerp(V[P[ab]], V[P[bb]], sx), sy);
  const double z1 = lerp(lerp(V[P[aa + 1]], V[P[ba + 1]], sx), lerp(V[P[ab + 1]], V[P[bb + 1]], sx), sy);
  return lerp(z0, z1, sz);
}

}  // namespace

double texture_factor(const SurfaceMaterial& material, const Eigen::Vector3d& p) {
  switch (material.texture) {
    case Texture::Plain: return 1.0;
    case Texture::Checker: {
      std::int64_t parity = 0;
      for (int axis = 0; axis < 3; ++axis)
        parity += static_cast<std::int64_t>(
            std::floor(p[axis] / material.scale + seed_offset(material.seed, axis)));
      return (parity & 1) ? 0.6 : 1.0;
    }
    case Texture::Noise: {
      // Octaves at 4x, 2x and 1x the scale: blotches with fine grain on top.
      double sum = 0.0;
      double amplitude = 0.5;
      double frequency = 0.25 / material.scale;
      for (int octave = 0; octave < 3; ++octave) {
        sum += amplitude * value_noise(material.seed + octave, p * frequency);
        amplitude *= 0.5;
        frequency *= 2.0;
      }
      return 0.7 + 0.55 * (sum / 0.875);
    }
  }
  return 1.0;
}

double shading_factor(const Eigen::Vector3d& n) {
  // A light from above and slightly aside, so walls facing different ways differ a little.
  static const Eigen::Vector3d kLight = Eigen::Vector3d(0.35, 0.25, 1.0).normalized();
  return 0.75 + 0.25 * std::max(0.0, n.dot(kLight));
}

double luminance(const Eigen::Vector3d& rgb) {
  return (0.2126 * rgb.x() + 0.7152 * rgb.y() + 0.0722 * rgb.z()) / 255.0;
}

}  // namespace locard::sim
