#pragma once
// Library-internal: a parallel, stable LSD radix sort of 64-bit items on a bit field.

#include <cstddef>
#include <cstdint>

namespace locard::detail {

// Sorts items[0, n) by the unsigned value of bits [low_bit, low_bit + key_bits) (key_bits <= 64 -
// low_bit). Stable: items with equal keys keep their relative order, so the result is unique
// and does not depend on the thread count. Passes of at most 11 bits each, per-chunk histograms
// and scatters run in parallel (oneTBB).
void parallel_radix_sort(std::uint64_t* items, std::size_t n, int low_bit, int key_bits);

}  // namespace locard::detail
