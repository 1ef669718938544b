#pragma once
// Counter-based random numbers: every draw is a hash of (seed, stream, view, pixel, counter),
// so a pixel's noise does not depend on which thread rendered it or in what order. That is
// what makes a simulated scan byte-identical for a seed on any number of cores.
//
// The mixer is the SplitMix64 finaliser (Steele, Lea, Flood, "Fast splittable pseudorandom
// number generators", OOPSLA 2014), applied once per key word.

#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>

namespace locard::sim {

constexpr std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

// Streams keep independent uses of one seed apart.
enum class RngStream : std::uint64_t {
  Pose = 1,
  DepthNoise = 2,
  ColorNoise = 3,
  LateralNoise = 4,
  SceneLayout = 5,  // random_scene: the room, its objects and the scan drawn from a seed
};

class CounterRng {
 public:
  CounterRng(std::uint64_t seed, RngStream stream, std::uint64_t view, std::uint64_t item)
      : key_(mix64(mix64(mix64(mix64(seed) ^ static_cast<std::uint64_t>(stream)) ^ view) ^ item)) {}

  std::uint64_t next_u64() { return mix64(key_ ^ mix64(counter_++)); }
  // Uniform in [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }
  // Two independent standard normals (Box-Muller): one log and one sin/cos pair for both.
  std::array<double, 2> normal_pair() {
    const double u1 = 1.0 - uniform();  // (0, 1]: log stays finite
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    const double phi = 2.0 * std::numbers::pi * u2;
    return {r * std::cos(phi), r * std::sin(phi)};
  }
  double normal() { return normal_pair()[0]; }
  // Approximately standard normal from one draw: the sum of four 16-bit uniforms, centred and
  // scaled to unit variance (Irwin-Hall). No libm call; good enough for 8-bit colour noise.
  double approx_normal() {
    const std::uint64_t bits = next_u64();
    double sum = 0.0;
    for (int k = 0; k < 4; ++k) sum += static_cast<double>((bits >> (16 * k)) & 0xFFFF) + 0.5;
    return (sum * 0x1.0p-16 - 2.0) * 1.7320508075688772;  // sqrt(3)
  }

 private:
  std::uint64_t key_;
  std::uint64_t counter_ = 0;
};

}  // namespace locard::sim
