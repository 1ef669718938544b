// The distinct-value estimate against exact counts, from empty to ten million values, with
// repeats, with the structured keys the voxel grid feeds it, and across merged counters.

#include "core/distinct_counter.hpp"

#include <gtest/gtest.h>

#include <cstdint>

namespace locard::detail {
namespace {

TEST(DistinctCounter, EmptyCountsZero) {
  EXPECT_EQ(DistinctCounter<>{}.estimate(), 0.0);
  EXPECT_EQ(DistinctCounter<6>{}.estimate(), 0.0);
}

TEST(DistinctCounter, WithinFivePercentOfExactCounts) {
  for (const std::uint64_t distinct :
       {1ull, 10ull, 1000ull, 50'000ull, 1'000'000ull, 10'000'000ull}) {
    DistinctCounter<> counter;
    for (std::uint64_t v = 0; v < distinct; ++v) counter.add(v);
    SCOPED_TRACE(distinct);
    EXPECT_NEAR(counter.estimate(), static_cast<double>(distinct), 0.05 * distinct + 0.5);
  }
}

TEST(DistinctCounter, SampledWithinTenPercentFromFiftyThousand) {
  // One value in 64 counted: ~800 sampled values at 50k, so a few percent of sampling error.
  for (const std::uint64_t distinct : {50'000ull, 1'000'000ull, 10'000'000ull}) {
    DistinctCounter<6> counter;
    for (std::uint64_t v = 0; v < distinct; ++v) counter.add(v * 3 + 11);
    SCOPED_TRACE(distinct);
    EXPECT_NEAR(counter.estimate(), static_cast<double>(distinct), 0.10 * distinct);
  }
}

TEST(DistinctCounter, RepeatsChangeNothing) {
  DistinctCounter<> once, thrice;
  for (std::uint64_t v = 0; v < 200'000; ++v) once.add(v * 977);
  for (int round = 0; round < 3; ++round) {
    for (std::uint64_t v = 200'000; v-- > 0;) thrice.add(v * 977);
  }
  EXPECT_EQ(once.estimate(), thrice.estimate());
}

TEST(DistinctCounter, StructuredVoxelKeys) {
  // Keys ((x * ny) + y) * nz + z of a thin slab, the shape of a scanned wall: highly regular
  // values that a weak hash would fold onto few registers.
  DistinctCounter<> counter;
  DistinctCounter<6> sampled;
  std::uint64_t distinct = 0;
  for (std::uint64_t x = 0; x < 600; ++x) {
    for (std::uint64_t y = 0; y < 300; ++y) {
      for (std::uint64_t z = 100; z < 104; ++z, ++distinct) {
        counter.add((x * 300 + y) * 300 + z);
        sampled.add((x * 300 + y) * 300 + z);
      }
    }
  }
  EXPECT_NEAR(counter.estimate(), static_cast<double>(distinct), 0.05 * distinct);
  EXPECT_NEAR(sampled.estimate(), static_cast<double>(distinct), 0.10 * distinct);
}

TEST(DistinctCounter, MergedCountersCountTheUnion) {
  DistinctCounter<> a, b, whole;
  for (std::uint64_t v = 0; v < 300'000; ++v) {
    (v % 3 == 0 ? a : b).add(v);
    if (v >= 100'000 && v < 200'000) a.add(v);  // overlap: counted once
    whole.add(v);
  }
  a.merge(b);
  EXPECT_EQ(a.estimate(), whole.estimate());
  EXPECT_NEAR(a.estimate(), 300'000.0, 15'000.0);
}

}  // namespace
}  // namespace locard::detail
