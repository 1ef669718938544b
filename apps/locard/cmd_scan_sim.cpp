// locard scan-sim: simulate a Kinect tripod scan of a scene (a file, a built-in, or a random
// room drawn from a seed) with exact ground truth.
#include "commands.hpp"

#include <locard/core/error.hpp>
#include <locard/core/progress.hpp>
#include <locard/sim/random_scene.hpp>
#include <locard/sim/scan_writer.hpp>
#include <locard/sim/scene.hpp>

#include <fmt/format.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <vector>
#include <string>

namespace locard::cli {
namespace {

struct ScanSimOptions {
  std::string scene;  // file, built-in name, or empty for the bedroom
  std::string output;
  std::optional<int> views;
  std::vector<double> pitch;  // pitch rows, degrees (overrides the scene's)
  std::optional<std::uint64_t> seed;
  std::optional<std::uint64_t> random;  // seed of a random room instead of a scene
  std::string sensor;                   // with --random: kinect_v1 | kinect_v2 (drawn if empty)
  std::string surfaces;                 // with --random: plain | textured (drawn if empty)
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

sim::RandomSceneOptions random_options(const ScanSimOptions& o) {
  sim::RandomSceneOptions options;
  if (!o.sensor.empty()) options.sensor = sim::parse_scanner_model(o.sensor);
  if (!o.surfaces.empty()) options.surfaces = sim::parse_surface_kind(o.surfaces);
  return options;
}

int run(const ScanSimOptions& o, const GlobalOptions& global) {
  const auto start = std::chrono::steady_clock::now();
  // Everything about the input is checked before the output folder is touched, so a bad scene
  // leaves nothing behind.
  if (o.random && !o.scene.empty())
    throw InputError("scan-sim: give a scene or --random SEED, not both");
  if (!o.random && (!o.sensor.empty() || !o.surfaces.empty()))
    throw InputError("scan-sim: --sensor and --surfaces apply to --random rooms only");
  sim::Scene scene = o.random ? sim::random_scene(*o.random, random_options(o)) : load_scene(o.scene);
  if (!o.pitch.empty()) {  // the rows replaced: every one gets --views, or the first row's count
    scene.scanner.set_rings(o.views ? *o.views : scene.scanner.views_in_ring(0), o.pitch);
  } else if (o.views) {
    scene.scanner.views = *o.views;
    scene.scanner.ring_views.clear();
  }
  if (o.seed) scene.scanner.seed = *o.seed;
  if (o.no_noise) scene.scanner.noise = false;
  // A random room's scene.json is generated, not read: write it as scanned, overrides included.
  if (o.random) scene.source_text = sim::scene_json(scene);
  sim::check_output_folder(o.output, o.force);
  if (o.random && !global.quiet) fmt::print("scan-sim: {}\n", sim::random_scene_summary(scene));

  const std::size_t total = scene.scanner.total_views();
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
      "Simulate a Kinect tripod scan of a scene (default: the built-in bedroom; or a random room "
      "with --random SEED) and write it as a TUM RGB-D folder with exact ground truth");
  cmd->add_option("scene", options->scene,
                  "Scene JSON file (docs/scene-format.md) or built-in scene name; default bedroom");
  cmd->add_option("--random", options->random,
                  "Draw a random room from SEED instead (size 2-8 m, 0-12 objects, tripod "
                  "anywhere, 1-3 pitch rings of 24-72 views, Kinect v1 or v2; "
                  "docs/simulator.md); prints what was drawn")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--sensor", options->sensor, "With --random: force the sensor")
      ->check(CLI::IsMember({"kinect_v1", "kinect_v2"}));
  cmd->add_option("--surfaces", options->surfaces,
                  "With --random: force plain (untextured) or textured surfaces")
      ->check(CLI::IsMember({"plain", "textured"}));
  cmd->add_option("-o,--output", options->output, "Output folder")->required();
  cmd->add_option("--views", options->views, "Views per pitch row (overrides the scene)")
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--pitch", options->pitch,
                  "Pitch rows in degrees, one per ring (overrides the scene's; positive looks "
                  "up), e.g. --pitch -10 for the bedroom's level ring alone")
      ->check(CLI::Range(-90.0, 90.0))
      ->allow_extra_args(false);
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
