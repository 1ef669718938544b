// `locard verify CASE_DIR`: re-hashes a case folder (the log's recorded outputs, its chain, the
// manifest, recorded inputs) and reports every changed, missing or added file. Exit 0 intact,
// 1 on any mismatch, 2 not a case, 3 (kExitCaseIncomplete) a case whose command did not finish.
#include "commands.hpp"

#include <locard/forensics/anchors.hpp>
#include <locard/forensics/case_folder.hpp>

#include <fmt/format.h>

#include <memory>

namespace locard::cli {
namespace {

struct VerifyCli {
  std::string case_dir;
  bool skip_inputs = false;
  std::string expect_head;
  std::string public_key;  // Ed25519, PEM: the case must carry a signature by it that holds
  std::string tsa_cert;    // the TSA's CA certificate, PEM: every stored time stamp must hold
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
  std::vector<std::string> notes;
  if (!o.public_key.empty()) fx::check_signatures(o.case_dir, o.public_key, r, notes);
  if (!o.tsa_cert.empty()) fx::check_timestamps(o.case_dir, o.tsa_cert, r, notes);
  for (const std::string& n : notes) fmt::print("verify: anchor {}\n", n);
  for (const fx::VerifyProblem& p : r.problems)
    fmt::print(stderr, "verify: {}: {} - {}\n", to_string(p.kind), p.path, p.detail);
  // An incomplete case is never "OK": it says so, and exits apart from a tampered one.
  const std::string verdict =
      r.ok() ? "OK, nothing changed" + since
      : r.only_incomplete()
          ? "INCOMPLETE: the command that made it did not finish (intact up to its last step)"
          : fmt::format("{} problem(s)", r.problems.size());
  if (!global.quiet || !r.ok())
    fmt::print("verify: {}: {} case files, {} inputs, {} log lines checked: {}\n", o.case_dir,
               r.files_checked, r.inputs_checked, r.log_lines, verdict);
  fmt::print("case log head: sha256 {}\n", r.log_head_sha256);
  if (r.ok()) return 0;
  return r.only_incomplete() ? fx::kExitCaseIncomplete : 1;
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
  cmd->add_option("--public-key", o->public_key,
                  "Ed25519 public key (PEM): exit 1 unless a signature by it (locard sign) holds "
                  "and its log head is still in the log");
  cmd->add_option("--tsa-cert", o->tsa_cert,
                  "CA certificate of the time-stamp authority (PEM): exit 1 unless every stored "
                  "RFC 3161 time stamp verifies and its log head is still in the log");
  set_runner(cmd, [o, &global] { return run_verify(*o, global); });
}

}  // namespace locard::cli
