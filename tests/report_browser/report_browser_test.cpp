// The case report in a real browser: headless Chromium loads report.html (offline, file://),
// its DOM must hold the stage-error plot (inline SVG) and the Table-I measurement table, and a
// screenshot of the page must show something (many colours, mostly not blank). Skipped only
// when no Chromium is installed.
#include <locard/forensics/report.hpp>
#include <locard/io/image_io.hpp>

#include <gtest/gtest.h>

#include "test_support.hpp"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>

namespace locard {
namespace {

namespace fs = std::filesystem;

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

int run(const std::string& command) { return std::system(command.c_str()); }

TEST(ReportBrowser, PlotAndTableArePresentInHeadlessChromium) {
  const fs::path chromium = forensics::find_chromium();
  if (chromium.empty()) GTEST_SKIP() << "no Chromium installed (chromium, chromium-browser)";
  const fs::path dir = test::scratch_dir();
  auto r = test::run_cli("scan-sim -o '" + (dir / "scan").string() + "' --views 50 --pitch -10");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // 8 views: part of the room, several Table-I rows measured, the rest reported as such.
  r = test::run_cli("--quiet reconstruct '" + (dir / "scan").string() + "' -o '" +
                    (dir / "case").string() + "' --frames 8 --voxel 0.04 --mesh-voxel 0.03");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const fs::path html = dir / "case" / "report" / "report.html";
  ASSERT_TRUE(fs::exists(html));
  // The PDF is printed by the same Chromium.
  ASSERT_TRUE(fs::exists(dir / "case" / "report" / "report.pdf")) << r.output;
  EXPECT_EQ(read(dir / "case" / "report" / "report.pdf").substr(0, 5), "%PDF-");

  const std::string flags = "--headless --no-sandbox --disable-gpu --no-first-run --user-data-dir='" +
                            (dir / "profile").string() + "'";
  const std::string url = "'file://" + fs::absolute(html).string() + "'";
  ASSERT_EQ(run("timeout 120 '" + chromium.string() + "' " + flags + " --dump-dom " + url + " > '" +
                (dir / "dom.html").string() + "' 2>'" + (dir / "chromium-dom.log").string() + "'"),
            0)
      << read(dir / "chromium-dom.log");
  const std::string dom = read(dir / "dom.html");
  EXPECT_NE(dom.find("id=\"stage-plot\""), std::string::npos);
  EXPECT_NE(dom.find("<svg"), std::string::npos);
  EXPECT_NE(dom.find("<polyline"), std::string::npos);  // the plotted error lines
  EXPECT_NE(dom.find("id=\"measurement-table\""), std::string::npos);
  EXPECT_NE(dom.find("<td>Window</td>"), std::string::npos);
  EXPECT_NE(dom.find("id=\"trajectory-plot\""), std::string::npos);
  // Plans carry a scale bar and axes; the measured rows are drawn on the dimensioned plan; the
  // coverage section is there (its plot, or why it was not computed).
  EXPECT_NE(dom.find("class=\"scale-bar\""), std::string::npos);
  EXPECT_NE(dom.find("class=\"axes\""), std::string::npos);
  EXPECT_NE(dom.find("id=\"floor-plan-plot\""), std::string::npos);
  EXPECT_NE(dom.find("class=\"dimension\""), std::string::npos);
  EXPECT_NE(dom.find("id=\"coverage\""), std::string::npos);
  EXPECT_NE(dom.find("id=\"output-hashes\""), std::string::npos);

  const fs::path shot = dir / "report-screenshot.png";
  ASSERT_EQ(run("timeout 120 '" + chromium.string() + "' " + flags +
                " --hide-scrollbars --window-size=1200,5200 --screenshot='" + shot.string() + "' " +
                url + " >'" + (dir / "chromium-shot.log").string() + "' 2>&1"),
            0)
      << read(dir / "chromium-shot.log");
  ASSERT_TRUE(fs::exists(shot));
  const ColorImage img = read_color_image(shot);
  ASSERT_EQ(img.width(), 1200);
  std::size_t ink = 0;
  std::set<std::uint32_t> colours;
  for (int v = 0; v < img.height(); ++v)
    for (int u = 0; u < img.width(); ++u) {
      const std::uint8_t* p = &img.at(u, v, 0);
      if (p[0] < 240 || p[1] < 240 || p[2] < 240) ++ink;
      colours.insert((p[0] >> 3) << 10 | (p[1] >> 3) << 5 | (p[2] >> 3));
    }
  EXPECT_GT(static_cast<double>(ink) / static_cast<double>(img.pixel_count()), 0.05);
  EXPECT_GT(colours.size(), 200u);  // rendered views and plots, not just text
  std::printf("report screenshot: %s\n", shot.string().c_str());
}

}  // namespace
}  // namespace locard
