// locard simulate: play an illustrative physics scenario (shots, falling or thrown objects,
// people) against a case's reconstructed mesh; writes simulations/<name>/ into the case.
#include "commands.hpp"

#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/case_simulation.hpp>
#include <locard/forensics/report.hpp>

#include <fmt/format.h>

#include <cstdint>
#include <map>
#include <optional>
#include <string>

namespace locard::cli {
namespace {

struct SimulateCliOptions {
  std::string case_dir;
  std::string scenario;
  std::optional<std::uint64_t> seed;
  std::optional<double> duration;
  std::optional<double> fps;
  bool force = false;
  bool no_report = false;
};

int run(const SimulateCliOptions& o, const GlobalOptions& global) {
  forensics::SimulateOptions options;
  options.force = o.force;
  options.seed = o.seed;
  options.duration = o.duration;
  options.fps = o.fps;
  const forensics::SimulateSummary s = forensics::simulate_case(o.case_dir, o.scenario, options);
  if (!global.quiet) {
    std::map<std::string, int> counts;
    for (const auto& e : s.result.events) ++counts[e.type];
    std::string listed;
    for (const auto& [type, n] : counts) listed += fmt::format("{}{} {}", listed.empty() ? "" : ", ", n, type);
    fmt::print("simulate: '{}' (ILLUSTRATIVE, not measured data): {:.2f} s in {} steps of {:.4f} s, "
               "seed {}, {:.2f} s of computing ({:.0f} steps/s)\n",
               s.scenario.name, s.scenario.duration, s.result.steps, s.scenario.time_step,
               s.scenario.seed, s.wall_seconds,
               s.wall_seconds > 0 ? static_cast<double>(s.result.steps) / s.wall_seconds : 0.0);
    fmt::print("simulate: events: {}\n", listed.empty() ? "none" : listed);
    for (const auto& e : s.result.events)
      if (e.type == "impact")
        fmt::print("simulate: {} hits {} at ({:.3f}, {:.3f}, {:.3f}) at t = {:.4f} s, {:.0f} m/s\n",
                   e.body, e.other, e.position.x(), e.position.y(), e.position.z(), e.time, e.speed);
    if (s.result.floor_inferred)
      fmt::print("simulate: floor inferred at height {:.3f} m (bodies rest on it where the scan "
                 "saw no floor)\n",
                 s.result.floor_height_m);
    fmt::print("simulate: wrote {}{}\n", s.folder.string(),
               s.logged ? " (logged in the case's log.jsonl)"
                        : " (not a Locard case folder: no manifest.json, so nothing was logged)");
  }
  // Warnings are printed even with --quiet: a body that left the model changes what the
  // simulation can be taken to show.
  for (const std::string& w : s.result.warnings) fmt::print(stderr, "simulate: warning: {}\n", w);
  if (s.logged && !o.no_report &&
      std::filesystem::is_regular_file(std::filesystem::path(o.case_dir) / "report" / "report.html")) {
    // The report lists the case's simulations (labelled illustrative): refreshed like every
    // other command that changes the case.
    forensics::CaseFolder folder = forensics::CaseFolder::open(o.case_dir, forensics::CaseAccess::Change);
    forensics::refresh_case_report(folder);
  }
  if (s.logged) print_log_head(o.case_dir);
  return 0;
}

}  // namespace

void register_simulate(CLI::App& app, GlobalOptions& global) {
  auto options = std::make_shared<SimulateCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "simulate",
      "Play an illustrative physics scenario (shots, dropped or thrown objects, people) against a "
      "case's reconstructed mesh; writes simulations/<name>/ (scenario.json, events.json, "
      "animation.glb). Not measured data.");
  cmd->add_option("case_dir", options->case_dir, "Case folder (holding mesh/mesh.ply)")->required();
  cmd->add_option("scenario", options->scenario, "Scenario JSON file (docs/scenarios.md)")->required();
  // CLI11 would wrap "-3" into a huge unsigned value: refuse negative numbers explicitly.
  cmd->add_option("--seed", options->seed, "Random seed (overrides the scenario's)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--duration", options->duration, "Simulated seconds (overrides the scenario's)")
      ->check(CLI::Range(0.001, 600.0));
  cmd->add_option("--fps", options->fps, "Animation samples per second (overrides the scenario's)")
      ->check(CLI::Range(1.0, 1000.0));
  cmd->add_flag("--no-report", options->no_report, "Do not rewrite the case's report");
  cmd->add_flag("--force", options->force, "Replace an existing simulation of the same name");
  set_runner(cmd, [options, &global] { return run(*options, global); });
}

}  // namespace locard::cli
