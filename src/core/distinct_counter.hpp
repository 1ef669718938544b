#pragma once
// An estimate of how many distinct 64-bit values a stream holds, in 4 KiB and a few
// instructions a value: HyperLogLog (Flajolet, Fusy, Gandouet, Meunier 2007) with 4096
// registers (standard error 1.6 %) and the linear-counting correction for small counts.
// Adding a value again changes nothing, so a caller may add repeats freely; counters of parts
// of a stream merge into the counter of the whole. The voxel grid sizes its hash tables with
// it: growing a table of millions of voxels while filling it cost a fifth of the run.
//
// With kSampleBits > 0 only the values that a cheap multiplicative hash puts in one of
// 2^kSampleBits classes are counted, and the estimate is scaled back: a value then costs a
// multiply and a well-predicted branch, for a few percent more error (the sample is a fixed
// subset of the value space, not of the stream, so repeats and the order do not matter).

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>

namespace locard::detail {

template <int kSampleBits = 0>
class DistinctCounter {
 public:
  static constexpr int kIndexBits = 12;
  static constexpr std::size_t kRegisters = std::size_t{1} << kIndexBits;

  void add(std::uint64_t value) {
    if constexpr (kSampleBits > 0) {
      if ((value * 0xD6E8FEB86659FD93ull) >> (64 - kSampleBits) != 0) return;
    }
    const std::uint64_t h = mix(value);
    const std::size_t index = h >> (64 - kIndexBits);
    // Rank of the first set bit after the index bits; the guard bit bounds it at 53.
    const std::uint64_t rest = (h << kIndexBits) | (std::uint64_t{1} << (kIndexBits - 1));
    const auto rank = static_cast<std::uint8_t>(std::countl_zero(rest) + 1);
    registers_[index] = std::max(registers_[index], rank);
  }

  void merge(const DistinctCounter& other) {
    for (std::size_t k = 0; k < kRegisters; ++k) {
      registers_[k] = std::max(registers_[k], other.registers_[k]);
    }
  }

  double estimate() const {
    constexpr double m = static_cast<double>(kRegisters);
    double harmonic = 0.0;
    std::size_t zeros = 0;
    for (const std::uint8_t r : registers_) {
      harmonic += std::ldexp(1.0, -r);
      zeros += r == 0;
    }
    const double raw = 0.7213 / (1.0 + 1.079 / m) * m * m / harmonic;
    const double sampled =
        raw <= 2.5 * m && zeros > 0 ? m * std::log(m / static_cast<double>(zeros)) : raw;
    return std::ldexp(sampled, kSampleBits);
  }

 private:
  static std::uint64_t mix(std::uint64_t x) {  // SplitMix64's finaliser: every bit mixed
    x ^= x >> 30;
    x *= 0xBF58476D1CE4E5B9ull;
    x ^= x >> 27;
    x *= 0x94D049BB133111EBull;
    return x ^ (x >> 31);
  }

  std::array<std::uint8_t, kRegisters> registers_{};
};

}  // namespace locard::detail
