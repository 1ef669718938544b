// Issue 14 (memory): an ASCII PLY or PCD of 110 points with 1000 properties each (a 230 KB
// file) took 412 MB to read. Every property is still kept (as a scalar field), and reading
// costs memory in proportion to the file: here under 48 MB of peak growth for both files.
// Each test runs in its own process (ctest), so the peak resident size starts small.
#include <locard/io/pcd.hpp>
#include <locard/io/ply.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <sys/resource.h>

#include <fstream>
#include <string>

namespace locard {
namespace {

namespace fs = std::filesystem;

constexpr int kPoints = 110, kProperties = 1000;

long peak_rss_kb() {
  rusage usage{};
  ::getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss;
}

std::string rows() {
  std::string body;
  for (int i = 0; i < kPoints; ++i) {
    body += std::to_string(i) + " 0 0";
    for (int p = 0; p < kProperties; ++p) body += " " + std::to_string(p % 7);
    body += "\n";
  }
  return body;
}

TEST(ManyProperties, AWideAsciiPlyAndPcdReadInMemoryLikeTheirSize) {
  const fs::path dir = test::scratch_dir();
  std::string ply = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(kPoints) +
                    "\nproperty float x\nproperty float y\nproperty float z\n";
  std::string fields = "x y z", sizes = "4 4 4", types = "F F F", counts = "1 1 1";
  for (int p = 0; p < kProperties; ++p) {
    ply += "property float p" + std::to_string(p) + "\n";
    fields += " p" + std::to_string(p);
    sizes += " 4";
    types += " F";
    counts += " 1";
  }
  ply += "end_header\n" + rows();
  std::ofstream(dir / "wide.ply") << ply;
  std::ofstream(dir / "wide.pcd") << "# .PCD v0.7\nVERSION 0.7\nFIELDS " << fields << "\nSIZE " << sizes
                                  << "\nTYPE " << types << "\nCOUNT " << counts << "\nWIDTH " << kPoints
                                  << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << kPoints
                                  << "\nDATA ascii\n" << rows();
  const long before = peak_rss_kb();
  for (const PointCloud& cloud : {read_ply(dir / "wide.ply"), read_pcd(dir / "wide.pcd")}) {
    ASSERT_EQ(cloud.size(), static_cast<std::size_t>(kPoints));
    ASSERT_EQ(cloud.scalars.size(), static_cast<std::size_t>(kProperties));
    EXPECT_EQ(cloud.scalars.back().values.size(), static_cast<std::size_t>(kPoints));
    EXPECT_FLOAT_EQ(cloud.scalars[5].values[3], 5.0f);
    EXPECT_FLOAT_EQ(cloud.positions[9].x(), 9.0f);
  }
  EXPECT_LT(peak_rss_kb() - before, 48 * 1024) << "KB of peak resident growth";
}

}  // namespace
}  // namespace locard
