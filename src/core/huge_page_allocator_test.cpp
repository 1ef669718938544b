// The large-array allocator: both paths (operator new below 4 MiB, aligned mappings above)
// hand out usable, 2 MiB-aligned (large) memory and give it back; the zeroed variant is zero
// on both paths.

#include "core/huge_page_allocator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <string>

namespace locard::detail {
namespace {

TEST(HugePageAllocator, LargeArraysAreAlignedAndWritable) {
  for (const std::size_t bytes : {std::size_t{1}, std::size_t{4096}, kLargeArray - 1, kLargeArray,
                                  kLargeArray + 1, std::size_t{37} << 20}) {
    auto* memory = static_cast<std::uint8_t*>(allocate_large(bytes));
    ASSERT_NE(memory, nullptr);
    if (bytes >= kLargeArray) {
      EXPECT_EQ(reinterpret_cast<std::uintptr_t>(memory) % kHugePage, 0u) << bytes;
    }
    memory[bytes - 1] = 2;
    memory[0] = 1;
    EXPECT_EQ(memory[0], 1);
    EXPECT_EQ(memory[bytes - 1], bytes == 1 ? 1 : 2);
    deallocate_large(memory, bytes);
  }
}

TEST(HugePageAllocator, ZeroedArraysAreZeroOnBothPaths) {
  for (const std::size_t bytes : {std::size_t{64}, kLargeArray - 8, kLargeArray, kLargeArray * 3}) {
    // Dirty the heap first, so that a small block reused from it would show old bytes.
    auto* dirty = static_cast<std::uint8_t*>(allocate_large(bytes));
    std::fill(dirty, dirty + bytes, std::uint8_t{0xAB});
    deallocate_large(dirty, bytes);
    auto* memory = static_cast<std::uint8_t*>(allocate_large_zeroed(bytes));
    EXPECT_EQ(std::count(memory, memory + bytes, std::uint8_t{0}),
              static_cast<std::ptrdiff_t>(bytes)) << bytes;
    deallocate_large(memory, bytes);
  }
}

// The process's mapped size in KiB (VmSize in /proc/self/status).
std::size_t mapped_kib() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmSize:", 0) == 0) return std::stoul(line.substr(7));
  }
  return 0;
}

TEST(HugePageAllocator, MappingsAreReturned) {
  const std::size_t before = mapped_kib();
  ASSERT_GT(before, 0u);
  for (int round = 0; round < 64; ++round) {  // 16 GiB mapped and unmapped in total
    LargeArray<std::uint8_t> array(std::size_t{256} << 20);
    array[0] = static_cast<std::uint8_t>(round);
    array[(std::size_t{256} << 20) - 1] = array[0];
    ASSERT_EQ(array[0], array[(std::size_t{256} << 20) - 1]);
  }
  EXPECT_LT(mapped_kib(), before + 64 * 1024);  // a leak would leave 16 GiB mapped
}

}  // namespace
}  // namespace locard::detail
