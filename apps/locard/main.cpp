// locard: command-line front end. Sub-commands live in cmd_*.cpp and register themselves here.
#include "commands.hpp"

#include <locard/core/error.hpp>
#include <locard/forensics/case_folder.hpp>

#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>

int main(int argc, char** argv) {
  CLI::App app{"Locard: forensic 3D reconstruction from RGB-D scans"};
  app.set_version_flag("--version", std::string("locard ") + LOCARD_VERSION);
  app.require_subcommand(1);
  locard::cli::GlobalOptions global;
  app.add_flag("-q,--quiet", global.quiet, "No progress bars or chatter (errors still shown)");
  locard::cli::register_all(app, global);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;  // usage errors are bad input too
  }
  try {
    return locard::cli::run_selected(app);
  } catch (const locard::forensics::CaseNotIntact& e) {
    std::fprintf(stderr, "locard: refused: %s\n", e.what());
    return locard::forensics::kExitCaseNotIntact;
  } catch (const locard::InputError& e) {
    std::fprintf(stderr, "locard: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "locard: error: %s\n", e.what());
    return 1;
  }
}
