// read_reference_measurements (measure --reference, reconstruct's Table I): a file that is not
// a regular file, not JSON or holds a number out of range (1e400) is an InputError naming the
// file - never a raw nlohmann exception (reference_fuzz found '-1e400':
// fuzz/corpus/reference/crash-minus-1e400.json) and never a blocking read.
#include <locard/forensics/measurement.hpp>

#include <locard/core/error.hpp>

#include <gtest/gtest.h>

#include "test_support.hpp"

#include <sys/stat.h>

#include <fstream>
#include <string>

namespace locard::forensics {
namespace {

namespace fs = std::filesystem;

fs::path write(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
  return p;
}

// The InputError's message (empty when another exception, or none, was thrown).
std::string read_error(const fs::path& path) {
  try {
    (void)read_reference_measurements(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return {};
}

TEST(ReferenceMeasurements, ReadsTheSimulatorsFile) {
  const fs::path p = write(test::scratch_dir() / "measurements.json",
                           R"({"measurements": [{"name": "Room width", "a": [-1.92, -0.3, 1.4],
                               "b": [1.92, -0.3, 1.4], "distance_m": 3.84, "source": "scene"}]})");
  const auto m = read_reference_measurements(p);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].name, "Room width");
  EXPECT_DOUBLE_EQ(m[0].true_distance_m, 3.84);
  EXPECT_DOUBLE_EQ(m[0].a.x(), -1.92);
}

TEST(ReferenceMeasurements, NumbersOutOfRangeNameTheFile) {
  const fs::path dir = test::scratch_dir();
  for (const char* number : {"1e400", "-1e400"}) {
    const fs::path p = write(dir / (std::string("reference") + number + ".json"),
                             std::string(R"({"measurements": [{"name": "m", "a": [0, 0, 0], )") +
                                 R"("b": [1, 0, 0], "distance_m": )" + number + "}]}");
    const std::string error = read_error(p);
    EXPECT_NE(error.find(p.filename().string()), std::string::npos) << number << ": " << error;
  }
  // The fuzzer's input: the number comes before a syntax error.
  const fs::path fuzzed = write(dir / "fuzzed.json",
                                R"({"meeeasumrnts":-1e400 [{"name": "do*r"}]})");
  EXPECT_NE(read_error(fuzzed).find("fuzzed.json"), std::string::npos);
}

TEST(ReferenceMeasurements, AFolderOrAFifoIsRefusedWithoutReading) {
  const fs::path dir = test::scratch_dir();
  EXPECT_NE(read_error(dir).find(dir.filename().string()), std::string::npos);
  const fs::path fifo = dir / "reference.fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_NE(read_error(fifo).find("reference.fifo"), std::string::npos);  // returns: no open()
}

}  // namespace
}  // namespace locard::forensics
