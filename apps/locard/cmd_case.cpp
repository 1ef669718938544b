// `locard case set CASE --number N --investigator NAME --location TEXT --date YYYY-MM-DD`:
// what a court exhibit names the case by (case_metadata.hpp), a logged step; the report is
// refreshed with it. `locard case show CASE` prints it.
#include "commands.hpp"

#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/case_metadata.hpp>
#include <locard/forensics/report.hpp>

#include <fmt/format.h>

#include <memory>
#include <optional>

namespace locard::cli {
namespace {

namespace fx = locard::forensics;

struct CaseCli {
  std::string case_dir;
  std::optional<std::string> number, investigator, location, date;
  bool no_report = false;
};

void print(const fx::CaseMetadata& m) {
  const auto or_unset = [](const std::string& s) { return s.empty() ? std::string("(not set)") : s; };
  fmt::print("case number:  {}\ninvestigator: {}\nlocation:     {}\ndate:         {}\n",
             or_unset(m.number), or_unset(m.investigator), or_unset(m.location), or_unset(m.date));
}

int run_set(const CaseCli& o) {
  fx::CaseFolder folder = fx::CaseFolder::open(o.case_dir, fx::CaseAccess::Change);
  const std::size_t seq =
      fx::set_case_metadata(folder, {o.number, o.investigator, o.location, o.date});
  if (!o.no_report) fx::refresh_case_report(folder);
  print(fx::read_case_metadata(folder));  // once saved: a receipt
  fmt::print("(log line {})\n", seq);
  print_log_head(folder.root());
  return 0;
}

int run_show(const CaseCli& o) {
  const fx::CaseFolder folder = fx::CaseFolder::open(o.case_dir, fx::CaseAccess::Read);
  print(fx::read_case_metadata(folder));
  return 0;
}

}  // namespace

void register_case(CLI::App& app, GlobalOptions&) {
  auto o = std::make_shared<CaseCli>();
  CLI::App* cmd = app.add_subcommand("case", "The case's number, investigator, location and date");
  cmd->require_subcommand(1);
  CLI::App* set = cmd->add_subcommand("set", "Set the case's metadata (a logged step; \"\" clears a field)");
  set->add_option("case", o->case_dir, "Case folder")->required();
  set->add_option("--number", o->number, "Case number");
  set->add_option("--investigator", o->investigator, "Investigator");
  set->add_option("--location", o->location, "Location of the scene");
  set->add_option("--date", o->date, "Date of the examination, YYYY-MM-DD");
  set->add_flag("--no-report", o->no_report, "Do not rewrite the report");
  CLI::App* show = cmd->add_subcommand("show", "Print the case's metadata");
  show->add_option("case", o->case_dir, "Case folder")->required();
  set_runner(cmd, [o, set, show] {
    if (set->parsed()) return run_set(*o);
    if (show->parsed()) return run_show(*o);
    return 2;
  });
}

}  // namespace locard::cli
