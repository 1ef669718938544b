#pragma once
// Sub-command registry. Each cmd_<name>.cpp defines register_<name>(), which adds its
// CLI11 sub-command and the callback that runs it.

#include <CLI/CLI.hpp>

#include <filesystem>
#include <functional>

namespace locard::cli {

struct GlobalOptions {
  bool quiet = false;
};

// After a command changed a case: its log head (forensics::log_head_sha256), printed even
// with --quiet, as it is the command's receipt: "case log head: sha256 <hex>".
void print_log_head(const std::filesystem::path& case_dir);

// Runs a sub-command; returns the process exit code.
using CommandRunner = std::function<int()>;

void register_all(CLI::App& app, GlobalOptions& global);
// Executes the sub-command the user chose.
int run_selected(CLI::App& app);
// Used by the cmd_*.cpp files to attach their runner to their sub-command.
void set_runner(CLI::App* subcommand, CommandRunner runner);

void register_info(CLI::App& app, GlobalOptions& global);
void register_convert(CLI::App& app, GlobalOptions& global);
void register_register(CLI::App& app, GlobalOptions& global);
void register_scan_sim(CLI::App& app, GlobalOptions& global);
void register_mesh(CLI::App&, GlobalOptions&);
void register_eval_mesh(CLI::App&, GlobalOptions&);
void register_align(CLI::App& app, GlobalOptions& global);
void register_eval_trajectory(CLI::App&, GlobalOptions&);
void register_reconstruct(CLI::App&, GlobalOptions&);
void register_verify(CLI::App&, GlobalOptions&);
void register_measure(CLI::App&, GlobalOptions&);
void register_marker(CLI::App&, GlobalOptions&);
void register_level(CLI::App&, GlobalOptions&);
void register_trajectory(CLI::App&, GlobalOptions&);
void register_simulate(CLI::App&, GlobalOptions&);
void register_view(CLI::App&, GlobalOptions&);
void register_sign(CLI::App&, GlobalOptions&);
void register_timestamp(CLI::App&, GlobalOptions&);
void register_evidence(CLI::App&, GlobalOptions&);
void register_case(CLI::App&, GlobalOptions&);

}  // namespace locard::cli
