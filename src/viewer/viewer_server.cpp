// The viewer's HTTP layer: cpp-httplib bound to 127.0.0.1, a token check before routing, and
// three kinds of route (the app, case files, the JSON API). Everything case-specific is in
// case_api.cpp; this file only moves bytes and refuses what is not allowed.
#include <locard/viewer/viewer_server.hpp>

#include <locard/core/error.hpp>
#include <locard/viewer/case_api.hpp>

#include <fmt/format.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include <array>
#include <condition_variable>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>
#include <random>
#include <sstream>
#include <thread>

namespace locard::viewer {
namespace {

namespace fs = std::filesystem;

constexpr const char* kLoopback = "127.0.0.1";

// DNS rebinding: a page on evil.example whose name is made to resolve to 127.0.0.1 reaches a
// loopback server from the user's browser, with Host: evil.example. Only requests addressed
// to this machine by a loopback name are answered (no Host at all: not a browser).
bool loopback_host(std::string_view host) {
  if (host.empty()) return true;
  if (host.starts_with("[")) {  // [::1]:port
    const std::size_t close = host.find(']');
    if (close == std::string_view::npos) return false;
    const std::string_view rest = host.substr(close + 1);
    if (!rest.empty() && !rest.starts_with(":")) return false;
    host = host.substr(1, close - 1);
  } else if (const std::size_t colon = host.rfind(':'); colon != std::string_view::npos) {
    host = host.substr(0, colon);
  }
  std::string lower(host);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower == "127.0.0.1" || lower == "localhost" || lower == "::1";
}

std::string mime_type(const fs::path& path) {
  static const std::map<std::string, std::string> types = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".json", "application/json"},
      {".jsonl", "application/x-ndjson"},
      {".glb", "model/gltf-binary"},
      {".gltf", "model/gltf+json"},
      {".svg", "image/svg+xml"},
      {".png", "image/png"},
      {".jpg", "image/jpeg"},
      {".csv", "text/csv; charset=utf-8"},
      {".txt", "text/plain; charset=utf-8"},
      {".pdf", "application/pdf"},
  };
  std::string ext = path.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const auto it = types.find(ext);
  return it == types.end() ? "application/octet-stream" : it->second;
}

// Reads a whole file; false when it cannot be opened or read.
bool read_file(const fs::path& path, std::string& out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) return false;
  out = std::move(buffer).str();
  return true;
}

void set_common_headers(httplib::Response& res) {
  res.set_header("Cache-Control", "no-store");
  res.set_header("X-Content-Type-Options", "nosniff");
  res.set_header("Referrer-Policy", "no-referrer");
  // Only this origin: no CDN, no remote font or script. blob:/data: for three.js textures.
  res.set_header("Content-Security-Policy",
                 "default-src 'self'; img-src 'self' blob: data:; connect-src 'self' blob: "
                 "data:; style-src 'self' 'unsafe-inline'; worker-src 'self' blob:; "
                 "object-src 'none'; base-uri 'none'; frame-ancestors 'none'");
}

void send_error(httplib::Response& res, int status, const std::string& message) {
  res.status = status;
  res.set_content(nlohmann::json{{"error", message}}.dump(), "application/json");
}

}  // namespace

std::string random_token() {
  std::random_device device;
  std::array<std::uint32_t, 4> words{};
  for (auto& w : words) w = device();
  std::string out;
  for (std::uint32_t w : words) out += fmt::format("{:08x}", w);
  return out;
}

bool token_matches(std::string_view expected, std::string_view given) {
  if (expected.empty()) return false;
  unsigned diff = expected.size() == given.size() ? 0u : 1u;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const char g = i < given.size() ? given[i] : '\0';
    diff |= static_cast<unsigned>(static_cast<unsigned char>(expected[i]) ^
                                  static_cast<unsigned char>(g));
  }
  return diff == 0;
}

fs::path find_web_root(const fs::path& executable) {
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("LOCARD_VIEWER_DIR"); env && *env) candidates.emplace_back(env);
  if (!executable.empty()) {
    std::error_code ec;
    const fs::path exe = fs::weakly_canonical(executable, ec);
    if (!ec) {
      candidates.push_back(exe.parent_path() / "viewer");  // the build tree: build/<preset>/
      candidates.push_back(exe.parent_path().parent_path() / "share/locard/viewer");
    }
  }
#ifdef LOCARD_VIEWER_BUILD_DIR
  candidates.emplace_back(LOCARD_VIEWER_BUILD_DIR);
#endif
  for (const fs::path& c : candidates) {
    std::error_code ec;
    if (fs::is_regular_file(c / "index.html", ec)) return c;
  }
  return {};
}

struct ViewerServer::Impl {
  ViewerServerOptions options;
  CaseApi api;
  httplib::Server server;
  std::thread thread;
  std::uint16_t port = 0;
  std::mutex api_mutex;  // the API reads caches and appends to the case log: one at a time

  // Debounced report refresh (see the header).
  std::thread report_thread;
  std::mutex report_mutex;
  std::condition_variable report_cv;
  bool report_pending = false;
  bool stopping = false;
  std::chrono::steady_clock::time_point report_due;

  void schedule_report() {
    {
      std::lock_guard lock(report_mutex);
      report_pending = true;
      report_due = std::chrono::steady_clock::now() + std::chrono::milliseconds(1500);
    }
    report_cv.notify_all();
  }

  void report_loop() {
    std::unique_lock lock(report_mutex);
    while (true) {
      if (!report_pending) {
        if (stopping) return;
        report_cv.wait(lock);
        continue;
      }
      if (!stopping && std::chrono::steady_clock::now() < report_due) {
        report_cv.wait_until(lock, report_due);
        continue;
      }
      report_pending = false;
      lock.unlock();
      try {
        std::lock_guard api_lock(api_mutex);
        api.refresh_report();
      } catch (const std::exception& e) {
        fmt::print(stderr, "view: the case report was not refreshed: {}\n", e.what());
      }
      lock.lock();
    }
  }

  explicit Impl(ViewerServerOptions o) : options(std::move(o)), api(options.case_dir) {}

  void serve_app_file(const std::string& name, httplib::Response& res) {
    // The bundle's own files only: a flat name, no separators.
    if (name.empty() || name.find('/') != std::string::npos ||
        name.find('\\') != std::string::npos || name.find("..") != std::string::npos) {
      send_error(res, 403, "refused");
      return;
    }
    std::string body;
    const fs::path path = options.web_root / name;
    std::error_code ec;
    if (!fs::is_regular_file(path, ec) || !read_file(path, body)) {
      send_error(res, 404, "not found");
      return;
    }
    // The page's own sub-resources (app.js, app.css) carry the token too: index.html names
    // them with a {{token}} placeholder, filled in here for a request that had the token.
    if (name == "index.html") {
      for (std::size_t at; (at = body.find("{{token}}")) != std::string::npos;)
        body.replace(at, 9, options.token);
    }
    res.set_content(std::move(body), mime_type(path).c_str());
  }

  void install_routes() {
    // httplib sends a reply's head and body in separate writes: with Nagle's algorithm on, the
    // body waited for the client's delayed ACK, 40-50 ms on every request over a kept-alive
    // connection (measured: 45 ms per API call, 1 ms with this).
    server.set_tcp_nodelay(true);
    server.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
      set_common_headers(res);
      if (!loopback_host(req.get_header_value("Host"))) {
        send_error(res, 403, "refused: the Host header names another machine; this server "
                             "answers only requests addressed to 127.0.0.1 or localhost");
        return httplib::Server::HandlerResponse::Handled;
      }
      std::string given = req.get_param_value("token");
      if (given.empty()) given = req.get_header_value("X-Locard-Token");
      if (!token_matches(options.token, given)) {
        send_error(res, 403, "forbidden: this server answers only requests that carry its "
                             "token (the URL `locard view` printed)");
        return httplib::Server::HandlerResponse::Handled;
      }
      return httplib::Server::HandlerResponse::Unhandled;
    });
    server.Get("/", [this](const httplib::Request&, httplib::Response& res) {
      serve_app_file("index.html", res);
    });
    server.Get(R"(/([A-Za-z0-9_.\-]+))", [this](const httplib::Request& req,
                                                 httplib::Response& res) {
      serve_app_file(req.matches[1].str(), res);
    });
    server.Get(R"(/case/(.+))", [this](const httplib::Request& req, httplib::Response& res) {
      const std::optional<fs::path> path = api.resolve_case_file(req.matches[1].str());
      if (!path) {
        send_error(res, 403, "refused: not a file inside the case folder");
        return;
      }
      std::string body;
      if (!read_file(*path, body)) {
        send_error(res, 404, "cannot read the file");
        return;
      }
      res.set_content(std::move(body), mime_type(*path).c_str());
    });
    const auto api_handler = [this](const httplib::Request& req, httplib::Response& res) {
      std::size_t max_points = 0;
      if (req.has_param("max")) {
        try {
          max_points = static_cast<std::size_t>(std::stoull(req.get_param_value("max")));
        } catch (const std::exception&) {
          send_error(res, 400, "max: expected a whole number");
          return;
        }
      }
      ApiResponse out;
      {
        std::lock_guard lock(api_mutex);
        out = api.handle(req.method, req.path, req.body, max_points);
      }
      if (out.status == 201) schedule_report();
      res.status = out.status;
      res.set_content(std::move(out.body), out.content_type.c_str());
    };
    server.Get(R"(/api/.*)", api_handler);
    server.Post(R"(/api/.*)", api_handler);
    server.set_exception_handler(
        [](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
          std::string what = "internal error";
          try {
            if (ep) std::rethrow_exception(ep);
          } catch (const std::exception& e) {
            what = e.what();
          } catch (...) {
          }
          send_error(res, 500, what);
        });
  }
};

ViewerServer::ViewerServer(ViewerServerOptions options) {
  if (options.token.empty()) options.token = random_token();
  std::error_code ec;
  if (!fs::is_regular_file(options.web_root / "index.html", ec))
    throw_input_error(options.web_root, "no index.html: the viewer bundle is missing");
  impl_ = std::make_unique<Impl>(std::move(options));
  impl_->install_routes();
}

ViewerServer::~ViewerServer() { stop(); }

void ViewerServer::start() {
  const int port = impl_->server.bind_to_any_port(kLoopback);
  if (port <= 0) throw Error(fmt::format("view: cannot bind a port on {}", kLoopback));
  impl_->port = static_cast<std::uint16_t>(port);
  impl_->thread = std::thread([this] { impl_->server.listen_after_bind(); });
  impl_->report_thread = std::thread([this] { impl_->report_loop(); });
}

void ViewerServer::stop() {
  if (!impl_) return;
  impl_->server.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
  {
    std::lock_guard lock(impl_->report_mutex);
    impl_->stopping = true;
  }
  impl_->report_cv.notify_all();
  if (impl_->report_thread.joinable()) impl_->report_thread.join();
}

std::uint16_t ViewerServer::port() const { return impl_->port; }
const std::string& ViewerServer::token() const { return impl_->options.token; }
std::string ViewerServer::url() const {
  return fmt::format("http://{}:{}/?token={}", kLoopback, impl_->port, impl_->options.token);
}

}  // namespace locard::viewer
