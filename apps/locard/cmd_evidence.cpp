// `locard evidence list|rename|withdraw CASE ...`: what a case records - evidence markers,
// measurements, trajectory analyses - listed as CSV, renamed or withdrawn as logged steps.
// Nothing is erased: see case_edits.hpp. The viewer offers the same edits.
#include "commands.hpp"

#include <locard/forensics/case_edits.hpp>
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/report.hpp>

#include <fmt/format.h>

#include <memory>

namespace locard::cli {
namespace {

namespace fx = locard::forensics;

struct EvidenceCli {
  std::string case_dir;
  std::string kind;       // marker, measurement or trajectory (checked by CLI11)
  std::string list_kind;  // empty: every kind
  std::string which, new_name, reason;
  bool no_report = false;
};

constexpr fx::CaseObjectKind kKinds[] = {fx::CaseObjectKind::Marker,
                                         fx::CaseObjectKind::Measurement,
                                         fx::CaseObjectKind::Trajectory};

int run_list(const EvidenceCli& o) {
  const fx::CaseFolder folder = fx::CaseFolder::open(o.case_dir, fx::CaseAccess::Read);
  for (fx::CaseObjectKind k : kKinds) {
    if (!o.list_kind.empty() && fx::parse_case_object_kind(o.list_kind) != k) continue;
    if (o.list_kind.empty())
      fmt::print("# {}\n", k == fx::CaseObjectKind::Trajectory ? std::string("trajectories")
                                                               : std::string(fx::to_string(k)) + "s");
    fmt::print("{}", fx::case_objects_csv(folder, k));
  }
  return 0;
}

int run_edit(const EvidenceCli& o, fx::CaseEditKind edit) {
  fx::CaseFolder folder = fx::CaseFolder::open(o.case_dir, fx::CaseAccess::Change);
  fx::CaseEdit e;
  e.object = *fx::parse_case_object_kind(o.kind);
  e.which = o.which;
  e.edit = edit;
  e.new_name = o.new_name;
  e.reason = o.reason;
  const fx::CaseEditResult r = fx::apply_case_edit(folder, e);
  if (!o.no_report) fx::refresh_case_report(folder);
  fmt::print("{} (log line {})\n", r.summary, r.log_seq);  // once saved: a receipt
  print_log_head(folder.root());
  return 0;
}

// The kind as text: CLI11 cannot take CaseObjectKind itself (it finds forensics::to_string by
// argument-dependent lookup and stops there), so the text is checked here and parsed once.
void add_kind(CLI::App* cmd, std::string& kind, bool required) {
  CLI::Option* opt = cmd->add_option("kind", kind, "marker, measurement or trajectory")
                         ->check(CLI::IsMember({"marker", "measurement", "trajectory"}));
  if (required) opt->required();
}

}  // namespace

void register_evidence(CLI::App& app, GlobalOptions&) {
  auto o = std::make_shared<EvidenceCli>();
  CLI::App* cmd = app.add_subcommand(
      "evidence", "What a case records (markers, measurements, trajectories): list as CSV, "
                  "rename, withdraw - each a logged step; nothing is erased");
  cmd->require_subcommand(1);
  CLI::App* list = cmd->add_subcommand("list", "Print markers, measurements and trajectories as CSV");
  list->add_option("case", o->case_dir, "Case folder")->required();
  add_kind(list, o->list_kind, false);

  CLI::App* rename = cmd->add_subcommand(
      "rename", "Give a marker a new label, or a measurement or trajectory a new name (the old "
                "one is kept beside it)");
  rename->add_option("case", o->case_dir, "Case folder")->required();
  add_kind(rename, o->kind, true);
  rename->add_option("which", o->which,
                     "A marker's number or label; a measurement's or trajectory's name, or #N "
                     "for the N-th")
      ->required();
  rename->add_option("new_name", o->new_name, "The new label or name")->required();
  rename->add_flag("--no-report", o->no_report, "Do not rewrite the report");

  CLI::App* withdraw = cmd->add_subcommand(
      "withdraw", "Withdraw a marker, measurement or trajectory: it stays in the case, marked "
                  "withdrawn with the reason, and is no longer used or drawn");
  withdraw->add_option("case", o->case_dir, "Case folder")->required();
  add_kind(withdraw, o->kind, true);
  withdraw->add_option("which", o->which, "As for rename")->required();
  withdraw->add_option("--reason", o->reason, "Why (kept with the object and logged)")->required();
  withdraw->add_flag("--no-report", o->no_report, "Do not rewrite the report");

  set_runner(cmd, [o, list, rename, withdraw] {
    if (list->parsed()) return run_list(*o);
    if (rename->parsed()) return run_edit(*o, fx::CaseEditKind::Rename);
    if (withdraw->parsed()) return run_edit(*o, fx::CaseEditKind::Withdraw);
    return 2;
  });
}

}  // namespace locard::cli
