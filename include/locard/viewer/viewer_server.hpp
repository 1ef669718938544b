#pragma once
// `locard view`'s local HTTP server: serves one case folder and the single-page viewer to a
// browser on the same machine, and nothing else.
//
//  - Binds 127.0.0.1 only (never 0.0.0.0 or ::), on a random free port chosen by the kernel.
//  - Every request must carry the per-run token, as `?token=...` or the header
//    `X-Locard-Token: ...`; without it (or with a wrong one) the answer is 403 and no content.
//    The token is 128 bits from std::random_device, written as 32 hex digits, and compared in
//    constant time.
//  - Routes:   /                   the viewer (index.html; app.js, app.css beside it)
//              /case/<relative>    a file of the case folder, read-only (path traversal: 403)
//              /api/...            CaseApi (see case_api.hpp)
//  - Responses carry `Cache-Control: no-store` and a Content-Security-Policy that allows only
//    this origin: the viewer loads no remote resource, so it works offline.
//  - After the API adds to the case (201), the case report is refreshed as the CLI does, on a
//    background thread, 1.5 s after the last addition (clicks in a row give one refresh);
//    stop() runs a refresh still due before it returns.

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace locard::viewer {

struct ViewerServerOptions {
  std::filesystem::path case_dir;
  std::filesystem::path web_root;  // folder with index.html and the bundle (app.js, app.css)
  std::string token;               // empty: a fresh random token
};

// 128 random bits from std::random_device as 32 lowercase hex digits.
std::string random_token();
// Compares without an early exit, so the time taken does not reveal the matching prefix.
bool token_matches(std::string_view expected, std::string_view given);

// Finds the viewer bundle (a folder with index.html): $LOCARD_VIEWER_DIR, then
// <folder of the executable>/viewer (the build tree), <folder of the executable>/../share/
// locard/viewer (an install), then the build tree's bundle (LOCARD_VIEWER_BUILD_DIR, set at
// compile time). Empty when none has index.html.
std::filesystem::path find_web_root(const std::filesystem::path& executable);

class ViewerServer {
 public:
  // Checks the case folder and the web root; throws InputError naming what is missing.
  explicit ViewerServer(ViewerServerOptions options);
  ~ViewerServer();
  ViewerServer(const ViewerServer&) = delete;
  ViewerServer& operator=(const ViewerServer&) = delete;

  // Binds 127.0.0.1 on a free port and serves on background threads. Throws Error when the
  // socket cannot be bound.
  void start();
  // Stops listening, runs a report refresh still due, and joins the threads (also done by the
  // destructor).
  void stop();

  std::uint16_t port() const;
  const std::string& token() const;
  // http://127.0.0.1:PORT/?token=TOKEN
  std::string url() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace locard::viewer
