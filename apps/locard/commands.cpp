#include "commands.hpp"

#include <locard/forensics/case_folder.hpp>

#include <cstdio>

#include <map>

namespace locard::cli {
namespace {
std::map<const CLI::App*, CommandRunner>& runners() {
  static std::map<const CLI::App*, CommandRunner> map;
  return map;
}
}  // namespace

void print_log_head(const std::filesystem::path& case_dir) {
  std::printf("case log head: sha256 %s\n", forensics::log_head_sha256(case_dir).c_str());
}

void set_runner(CLI::App* subcommand, CommandRunner runner) {
  runners()[subcommand] = std::move(runner);
}

void register_all(CLI::App& app, GlobalOptions& global) {
  register_info(app, global);
  register_convert(app, global);
  register_register(app, global);
  register_scan_sim(app, global);
  register_mesh(app, global);
  register_eval_mesh(app, global);
  register_align(app, global);
  register_eval_trajectory(app, global);
  register_reconstruct(app, global);
  register_verify(app, global);
  register_measure(app, global);
  register_marker(app, global);
  register_level(app, global);
  register_trajectory(app, global);
  register_simulate(app, global);
  register_view(app, global);
  register_sign(app, global);
  register_timestamp(app, global);
  register_evidence(app, global);
  register_case(app, global);
}

int run_selected(CLI::App& app) {
  for (const CLI::App* sub : app.get_subcommands()) {
    auto it = runners().find(sub);
    if (it != runners().end()) return it->second();
  }
  return 2;
}

}  // namespace locard::cli
