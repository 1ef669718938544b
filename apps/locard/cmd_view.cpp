// `locard view CASE_DIR`: serves the case to a browser on this machine only (127.0.0.1, a
// random free port, a per-run token in the URL), opens the viewer unless --no-browser, and
// serves until Ctrl-C (or --exit-after SECONDS). The server is locard::viewer::ViewerServer;
// the viewer itself is a bundle built at build time (web/viewer).
#include "commands.hpp"

#include <locard/core/error.hpp>
#include <locard/viewer/viewer_server.hpp>

#include <fmt/format.h>

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <thread>

extern char** environ;

namespace locard::cli {
namespace {

namespace fs = std::filesystem;

struct ViewOptions {
  std::string case_dir;
  bool no_browser = false;
  double exit_after = 0.0;  // seconds; 0: serve until interrupted
};

std::atomic<bool> g_stop{false};
extern "C" void on_stop_signal(int) { g_stop.store(true); }

fs::path executable_path() {
  std::error_code ec;
  fs::path p = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path() : p;
}

// xdg-open on PATH, or empty.
fs::path find_on_path(const char* name) {
  const char* path = std::getenv("PATH");
  if (!path) return {};
  std::string_view rest(path);
  while (!rest.empty()) {
    const std::size_t colon = rest.find(':');
    const std::string dir(rest.substr(0, colon));
    rest = colon == std::string_view::npos ? std::string_view() : rest.substr(colon + 1);
    if (dir.empty()) continue;
    const fs::path candidate = fs::path(dir) / name;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return {};
}

// Starts xdg-open URL without a shell (the URL is passed as one argument); false when there
// is no xdg-open or it cannot be started.
bool open_browser(const std::string& url) {
  const fs::path opener = find_on_path("xdg-open");
  if (opener.empty()) return false;
  pid_t pid = 0;
  std::string program = opener.string();
  std::string argument = url;
  char* argv[] = {program.data(), argument.data(), nullptr};
  if (posix_spawn(&pid, program.c_str(), nullptr, nullptr, argv, environ) != 0) return false;
  // xdg-open hands the URL to the browser and returns; reap it so no zombie is left.
  std::thread([pid] {
    int status = 0;
    ::waitpid(pid, &status, 0);
  }).detach();
  return true;
}

int run_view(const ViewOptions& o, const GlobalOptions& global) {
  const fs::path web_root = viewer::find_web_root(executable_path());
  if (web_root.empty()) {
    throw InputError(
        "view: this locard was built without the viewer bundle (npm was missing at build "
        "time, or the bundle was not installed); rebuild with Node.js and npm present, or set "
        "LOCARD_VIEWER_DIR to a folder holding the built viewer (index.html, app.js)");
  }
  viewer::ViewerServerOptions options;
  options.case_dir = o.case_dir;
  options.web_root = web_root;
  viewer::ViewerServer server(options);
  server.start();

  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
  fmt::print("{}\n", server.url());
  if (!global.quiet)
    fmt::print(stderr, "view: serving {} on 127.0.0.1:{} (only this machine; Ctrl-C stops)\n",
               o.case_dir, server.port());
  std::fflush(stdout);
  std::fflush(stderr);
  if (!o.no_browser && !open_browser(server.url()) && !global.quiet)
    fmt::print(stderr, "view: no xdg-open found; open the URL above in a browser\n");

  const auto start = std::chrono::steady_clock::now();
  while (!g_stop.load()) {
    if (o.exit_after > 0.0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >=
            o.exit_after)
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  server.stop();
  if (!global.quiet) fmt::print(stderr, "view: stopped\n");
  return 0;
}

}  // namespace

void register_view(CLI::App& app, GlobalOptions& global) {
  auto opt = std::make_shared<ViewOptions>();
  CLI::App* sub = app.add_subcommand(
      "view", "Open a case in the 3D viewer: serves it on 127.0.0.1 (random port, per-run "
              "token in the printed URL) and opens a browser; measurements, evidence markers "
              "and trajectories placed there are saved into the case through its integrity log");
  sub->add_option("case_dir", opt->case_dir, "Case folder (from `locard reconstruct`)")
      ->required();
  sub->add_flag("--no-browser", opt->no_browser, "Only print the URL; do not open a browser");
  sub->add_option("--exit-after", opt->exit_after,
                  "Stop serving after this many seconds (default: serve until Ctrl-C)")
      ->check(CLI::NonNegativeNumber);
  set_runner(sub, [opt, &global]() { return run_view(*opt, global); });
}

}  // namespace locard::cli
