// locard scan-sim: simulate a Kinect v2 tripod scan of a scene with exact ground truth.
#include "commands.hpp"

#include <locard/core/error.hpp>
#include <locard/core/progress.hpp>
#include <locard/sim/scan_writer.hpp>
#include <locard/sim/scene.hpp>

#include <fmt/format.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace locard::cli {
namespace {

struct ScanSimOptions {
  std::string scene;  // file, built-in name, or empty for the bedroom
  std::string output;
  std::optional<int> views;
  std::optional<std::uint64_t> seed;
  bool no_noise = false;
  bool color_hd = false;
  bool force = false;
};

sim::Scene load_scene(const std::string& argument) {
  namespace fs = std::filesystem;
  if (argument.empty()) return sim::builtin_scene("bedroom");
  if (fs::exists(argument)) return sim::read_scene(argument);
  for (const auto& name : sim::builtin_scene_names())
    if (name == argument) return sim::builtin_scene(name);
  std::string known;
  for (const auto& name : sim::builtin_scene_names()) known += (known.empty() ? "" : ", ") + name;
  throw_input_error(argument, "no such scene file, nor a built-in scene (built-in: " + known + ")");
}

int run(const ScanSimOptions& o, const GlobalOptions& global) {
  const auto start = std::chrono::steady_clock::now();
  // Everything about the input is checked before the output folder is touched, so a bad scene
  // leaves nothing behind.
  sim::Scene scene = load_scene(o.scene);
  if (o.views) scene.scanner.views = *o.views;
  if (o.seed) scene.scanner.seed = *o.seed;
  if (o.no_noise) scene.scanner.noise = false;
  sim::check_output_folder(o.output, o.force);

  const std::size_t total = scene.scanner.views * scene.scanner.pitch_deg.size();
  ProgressBar bar("scan-sim", total, ProgressBar::should_show(global.quiet));
  sim::ScanWriteOptions options;
  options.force = o.force;
  options.color_hd = o.color_hd;
  options.progress = bar.callback();
  const sim::ScanWriteSummary summary = sim::write_simulated_scan(scene, o.output, options);
  bar.finish();

  if (!global.quiet) {
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double valid = summary.depth_pixels
                             ? 100.0 * static_cast<double>(summary.valid_depth_pixels) /
                                   static_cast<double>(summary.depth_pixels)
                             : 0.0;
    fmt::print("scan-sim: scene '{}', {} views (seed {}, noise {}), {:.1f}% depth pixels valid\n",
               scene.name, summary.views, scene.scanner.seed,
               scene.scanner.noise ? "on" : "off", valid);
    fmt::print("scan-sim: wrote {} ({} mesh triangles, {} measurements) in {:.1f} s\n", o.output,
               summary.triangles, summary.measurements, seconds);
  }
  return 0;
}

}  // namespace

void register_scan_sim(CLI::App& app, GlobalOptions& global) {
  auto options = std::make_shared<ScanSimOptions>();
  CLI::App* cmd = app.add_subcommand(
      "scan-sim",
      "Simulate a Kinect v2 tripod scan of a scene (default: the built-in bedroom) and write it "
      "as a TUM RGB-D folder with exact ground truth");
  cmd->add_option("scene", options->scene,
                  "Scene JSON file (docs/scene-format.md) or built-in scene name; default bedroom");
  cmd->add_option("-o,--output", options->output, "Output folder")->required();
  cmd->add_option("--views", options->views, "Views per pitch row (overrides the scene)")
      ->check(CLI::Range(1, 100000));
  // CLI11 would wrap "-3" into a huge unsigned value: refuse negative numbers explicitly.
  cmd->add_option("--seed", options->seed, "Random seed (overrides the scene)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--no-noise", options->no_noise, "Exact depth and colour, no sensor noise");
  cmd->add_flag("--color-hd", options->color_hd,
                "Also write 1920x1080 colour (rgb_hd/, same poses)");
  cmd->add_flag("--force", options->force, "Write into a folder that is not empty");
  set_runner(cmd, [options, &global] { return run(*options, global); });
}

}  // namespace locard::cli
