#include "core/parallel_radix_sort.hpp"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <memory>
#include <vector>

namespace locard::detail {

void parallel_radix_sort(std::uint64_t* items, std::size_t n, int low_bit, int key_bits) {
  if (n < 2 || key_bits <= 0) return;
  const int passes = (key_bits + 10) / 11;
  const int digit_bits = (key_bits + passes - 1) / passes;
  const std::size_t buckets = std::size_t{1} << digit_bits;
  const std::uint64_t mask = buckets - 1;

  // Chunks: a few per thread so that the scatter balances; at least ~16k items each.
  const std::size_t max_chunks =
      static_cast<std::size_t>(std::max(1, tbb::this_task_arena::max_concurrency())) * 4;
  const std::size_t chunks = std::clamp<std::size_t>(n / 16384, 1, max_chunks);
  const std::size_t chunk_size = (n + chunks - 1) / chunks;

  // Uninitialised scratch: every slot is written by the first scatter.
  const auto scratch = std::make_unique_for_overwrite<std::uint64_t[]>(n);
  std::vector<std::size_t> offsets(chunks * buckets);  // [chunk][digit]
  std::uint64_t* source = items;
  std::uint64_t* target = scratch.get();

  for (int pass = 0; pass < passes; ++pass) {
    const int shift = low_bit + pass * digit_bits;
    // 1. Histogram of each chunk.
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
      std::size_t* histogram = offsets.data() + c * buckets;
      std::fill(histogram, histogram + buckets, 0);
      const std::size_t end = std::min(n, (c + 1) * chunk_size);
      for (std::size_t i = c * chunk_size; i < end; ++i) ++histogram[(source[i] >> shift) & mask];
    });
    // 2. Exclusive prefix in (digit, chunk) order: chunk c's items of digit d go after every
    //    smaller digit and after the digit-d items of chunks before c (this is the stability).
    std::size_t running = 0;
    for (std::size_t d = 0; d < buckets; ++d) {
      for (std::size_t c = 0; c < chunks; ++c) {
        const std::size_t count = offsets[c * buckets + d];
        offsets[c * buckets + d] = running;
        running += count;
      }
    }
    // 3. Scatter.
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
      std::size_t* next = offsets.data() + c * buckets;
      const std::size_t end = std::min(n, (c + 1) * chunk_size);
      for (std::size_t i = c * chunk_size; i < end; ++i) {
        target[next[(source[i] >> shift) & mask]++] = source[i];
      }
    });
    std::swap(source, target);
  }
  if (source != items) std::copy(source, source + n, items);
}

}  // namespace locard::detail
