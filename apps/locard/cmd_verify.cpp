// `locard verify CASE_DIR`: re-hashes a case folder (manifest, log chain, recorded inputs) and
// reports every changed, missing or added file. Exit 0 intact, 1 on any mismatch, 2 not a case.
#include "commands.hpp"

#include <locard/forensics/case_folder.hpp>

#include <fmt/format.h>

#include <memory>

namespace locard::cli {
namespace {

struct VerifyCli {
  std::string case_dir;
  bool skip_inputs = false;
  std::string expect_head;
};

int run_verify(const VerifyCli& o, const GlobalOptions& global) {
  namespace fx = locard::forensics;
  fx::VerifyReport r = fx::verify_case(o.case_dir, !o.skip_inputs);
  // A head printed earlier must still be a line of the log: steps after it are additions
  // (reported), a head that is gone means the steps up to it were rewritten or removed.
  std::string since;
  if (!o.expect_head.empty()) {
    const std::optional<std::size_t> at = fx::find_log_line(o.case_dir, o.expect_head);
    if (!at)
      r.problems.push_back({fx::VerifyProblem::Kind::LogChain, "log.jsonl",
                            fmt::format("no log line hashes to {} (the head printed earlier): "
                                        "the steps up to it were rewritten or removed",
                                        o.expect_head)});
    else if (*at + 1 < r.log_lines)
      since = fmt::format("; {} step(s) logged after the expected head", r.log_lines - *at - 1);
    else
      since = "; the log ends at the expected head";
  }
  for (const fx::VerifyProblem& p : r.problems)
    fmt::print(stderr, "verify: {}: {} - {}\n", to_string(p.kind), p.path, p.detail);
  if (!global.quiet || !r.ok())
    fmt::print("verify: {}: {} case files, {} inputs, {} log lines checked: {}\n", o.case_dir,
               r.files_checked, r.inputs_checked, r.log_lines,
               r.ok() ? "OK, nothing changed" + since
                      : fmt::format("{} problem(s)", r.problems.size()));
  fmt::print("case log head: sha256 {}\n", r.log_head_sha256);
  return r.ok() ? 0 : 1;
}

}  // namespace

void register_verify(CLI::App& app, GlobalOptions& global) {
  auto o = std::make_shared<VerifyCli>();
  CLI::App* cmd = app.add_subcommand(
      "verify", "Check a case folder's integrity: re-hash every file, the log's hash chain and "
                "the original inputs; exit 1 naming each changed, missing or added file");
  cmd->add_option("case", o->case_dir, "Case folder")->required();
  cmd->add_flag("--skip-inputs", o->skip_inputs,
                "Do not re-hash the original inputs (only the case folder was copied)");
  cmd->add_option("--expect-head", o->expect_head,
                  "A log head (sha256 hex) a command printed earlier: exit 1 unless the log "
                  "still holds it (later steps are reported, not refused)");
  set_runner(cmd, [o, &global] { return run_verify(*o, global); });
}

}  // namespace locard::cli
