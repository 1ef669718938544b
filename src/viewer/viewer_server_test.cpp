// The viewer's server over real sockets (test::http_request, a minimal HTTP/1.0 client apart
// from the server's own library): the token is
// required on every route, path traversal is refused, the API answers and a marker saved
// through it lands in the case's integrity log. Measurements and trajectories need a
// reconstructed case; tests/browser covers them end to end.
#include <locard/forensics/case_folder.hpp>
#include <locard/viewer/case_api.hpp>
#include <locard/viewer/viewer_server.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace locard::viewer {
namespace {

namespace fs = std::filesystem;

void write_text(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

using test::Reply;

struct Fixture {
  fs::path dir = test::scratch_dir();
  fs::path case_dir = dir / "case";
  fs::path web_root = dir / "web";

  Fixture() {
    forensics::CaseFolder folder = forensics::CaseFolder::create(case_dir, false);
    write_text(case_dir / "case.json", R"({"title": "test case"})");
    write_text(case_dir / "mesh/mesh.json", R"({"triangles": 2, "inferred_triangles": 1})");
    write_text(case_dir / "simulations/drop/events.json", R"({"events": []})");
    write_text(case_dir / "simulations/drop/animation.glb", "glTF");
    forensics::LogStep step;
    step.step = "test fixture";
    step.outputs = {"case.json", "mesh/mesh.json", "simulations/drop/events.json",
                    "simulations/drop/animation.glb"};
    folder.append_log_step(step);
    write_text(web_root / "index.html", "<!doctype html><title>viewer</title>");
    write_text(web_root / "app.js", "console.log(1);");
    write_text(dir / "secret.txt", "outside the case");
  }
};

TEST(ViewerToken, Is128BitHexAndFresh) {
  std::set<std::string> seen;
  for (int i = 0; i < 64; ++i) {
    const std::string t = random_token();
    ASSERT_EQ(t.size(), 32u);
    EXPECT_EQ(t.find_first_not_of("0123456789abcdef"), std::string::npos) << t;
    seen.insert(t);
  }
  EXPECT_EQ(seen.size(), 64u);
}

TEST(ViewerToken, MatchesOnlyTheWholeToken) {
  const std::string t = "0123456789abcdef0123456789abcdef";
  EXPECT_TRUE(token_matches(t, t));
  EXPECT_FALSE(token_matches(t, ""));
  EXPECT_FALSE(token_matches(t, t.substr(0, 31)));
  EXPECT_FALSE(token_matches(t, t + "0"));
  EXPECT_FALSE(token_matches(t, "1123456789abcdef0123456789abcdef"));
  EXPECT_FALSE(token_matches("", ""));  // no token configured: nothing matches
}

TEST(CaseApi, ResolvesOnlyFilesInsideTheCase) {
  Fixture f;
  fs::create_symlink(f.dir / "secret.txt", f.case_dir / "link.txt");
  const CaseApi api(f.case_dir);
  EXPECT_TRUE(api.resolve_case_file("case.json"));
  EXPECT_TRUE(api.resolve_case_file("mesh/mesh.json"));
  EXPECT_FALSE(api.resolve_case_file(""));
  EXPECT_FALSE(api.resolve_case_file("../secret.txt"));
  EXPECT_FALSE(api.resolve_case_file("mesh/../../secret.txt"));
  EXPECT_FALSE(api.resolve_case_file("mesh/../case.json"));  // no ".." at all
  EXPECT_FALSE(api.resolve_case_file("./case.json"));
  EXPECT_FALSE(api.resolve_case_file((f.dir / "secret.txt").string()));
  EXPECT_FALSE(api.resolve_case_file("mesh\\..\\..\\secret.txt"));
  EXPECT_FALSE(api.resolve_case_file("link.txt"));  // a symbolic link out of the case
  EXPECT_FALSE(api.resolve_case_file("mesh"));      // a folder
  EXPECT_FALSE(api.resolve_case_file("missing.json"));
}

TEST(ViewerServer, RefusesRequestsWithoutTheToken) {
  Fixture f;
  ViewerServer server({f.case_dir, f.web_root, ""});
  server.start();
  ASSERT_GT(server.port(), 0);
  EXPECT_EQ(server.url(), "http://127.0.0.1:" + std::to_string(server.port()) +
                              "/?token=" + server.token());
  const std::uint16_t port = server.port();
  const std::string q = "?token=" + server.token();
  for (const std::string path : {"/", "/app.js", "/api/case", "/api/markers", "/case/case.json"}) {
    Reply r = test::http_request(port, "GET", path);
    EXPECT_EQ(r.status, 403) << path;
    EXPECT_EQ(r.body.find("viewer"), std::string::npos);
    r = test::http_request(port, "GET", path + "?token=" + std::string(32, '0'));
    EXPECT_EQ(r.status, 403) << path << " with a wrong token";
    r = test::http_request(port, "GET", path, {{"X-Locard-Token", server.token().substr(0, 31)}});
    EXPECT_EQ(r.status, 403) << path << " with a truncated token";
  }
  const Reply post = test::http_request(port, "POST", "/api/markers", {},
                             R"({"position": [0, 0, 0], "label": "x", "snap": false})");
  EXPECT_EQ(post.status, 403);
  EXPECT_FALSE(fs::exists(f.case_dir / "evidence/markers.json"));

  Reply ok = test::http_request(port, "GET", "/" + q);
  EXPECT_EQ(ok.status, 200);
  EXPECT_NE(ok.body.find("viewer"), std::string::npos);
  EXPECT_EQ(ok.headers["cache-control"], "no-store");
  EXPECT_NE(ok.headers["content-security-policy"].find("default-src 'self'"), std::string::npos);
  ok = test::http_request(port, "GET", "/api/case", {{"X-Locard-Token", server.token()}});
  EXPECT_EQ(ok.status, 200);
  const auto summary = nlohmann::json::parse(ok.body);
  EXPECT_EQ(summary["case"]["title"], "test case");
  EXPECT_EQ(summary["view"]["inferred_triangles"], 1);
  ASSERT_EQ(summary["view"]["simulations"].size(), 1u);
  EXPECT_EQ(summary["view"]["simulations"][0]["animation"], "simulations/drop/animation.glb");
  server.stop();
}

// Issue 14 (DNS rebinding): with the right token, a request whose Host names another machine is
// refused; loopback names with or without a port are answered.
TEST(ViewerServer, AnswersOnlyRequestsAddressedToThisMachine) {
  Fixture f;
  ViewerServer server({f.case_dir, f.web_root, ""});
  server.start();
  const std::uint16_t port = server.port();
  const std::string target = "/api/case?token=" + server.token();
  const std::string p = ":" + std::to_string(port);
  for (const std::string& host : std::vector<std::string>{"evil.example", "evil.example" + p, "127.0.0.1.evil.example",
                                 "192.168.1.20" + p, "[::2]" + p, "localhost.evil"})
    EXPECT_EQ(test::http_request(port, "GET", target, {{"Host", host}}).status, 403) << host;
  for (const std::string& host :
       std::vector<std::string>{"127.0.0.1" + p, "localhost" + p, "LOCALHOST", "[::1]" + p})
    EXPECT_EQ(test::http_request(port, "GET", target, {{"Host", host}}).status, 200) << host;
  server.stop();
}

TEST(ViewerServer, RefusesPathTraversal) {
  Fixture f;
  ViewerServer server({f.case_dir, f.web_root, ""});
  server.start();
  const std::uint16_t port = server.port();
  const std::string q = "?token=" + server.token();
  for (const std::string path :
       {"/case/../secret.txt", "/case/..%2fsecret.txt", "/case/mesh/..%2f..%2fsecret.txt",
        "/case/%2e%2e/secret.txt", "/case/..%5csecret.txt", "/..%2fsecret.txt",
        "/case/%2fetc%2fpasswd", "/case//etc/passwd"}) {
    const Reply r = test::http_request(port, "GET", path + q);
    EXPECT_TRUE(r.status == 403 || r.status == 404) << path << ": " << r.status;
    EXPECT_EQ(r.body.find("outside the case"), std::string::npos) << path;
  }
  const Reply r = test::http_request(port, "GET", "/case/mesh/mesh.json" + q);
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.headers.at("content-type"), "application/json");
}

TEST(ViewerServer, SavesMarkersThroughTheIntegrityLog) {
  Fixture f;
  ViewerServer server({f.case_dir, f.web_root, ""});
  server.start();
  const std::uint16_t port = server.port();
  const std::map<std::string, std::string> auth = {{"X-Locard-Token", server.token()}};
  Reply r = test::http_request(port, "POST", "/api/markers", auth,
                    R"({"position": [1.0, 2.0, 0.5], "label": "Casing", "note": "n",
                        "snap": false})");
  ASSERT_EQ(r.status, 201) << r.body;
  const auto marker = nlohmann::json::parse(r.body);
  EXPECT_EQ(marker["number"], 1);
  EXPECT_EQ(marker["world"], nlohmann::json::array({1.0, 2.0, 0.5}));
  // Bad input: 400 with a message, and nothing written.
  for (const std::string body :
       {"not json", R"({"label": "x"})", R"({"position": [1, 2], "label": "x"})",
        R"({"position": [1, "a", 3], "label": "x"})",
        // Issue 14: a wrong type answered 500 with nlohmann's exception text.
        R"({"position": [1, 2, 3], "label": "y", "snap": "yes"})",
        R"({"position": [1, 2, 1e400], "label": "z", "snap": false})",
        R"({"position": [1, 2, 3], "label": 7, "snap": false})",
        R"({"position": [1, 2, 3], "label": "Casing", "snap": false})"}) {
    r = test::http_request(port, "POST", "/api/markers", auth, body);
    EXPECT_EQ(r.status, 400) << body << ": " << r.body;
    EXPECT_TRUE(nlohmann::json::parse(r.body).contains("error")) << r.body;
  }
  r = test::http_request(port, "GET", "/api/markers", auth);
  const auto list = nlohmann::json::parse(r.body)["markers"];
  ASSERT_EQ(list.size(), 1u);
  EXPECT_EQ(list[0]["label"], "Casing");
  r = test::http_request(port, "GET", "/api/nothing", auth);
  EXPECT_EQ(r.status, 404);

  std::ifstream log(f.case_dir / "log.jsonl");
  std::string line, last;
  while (std::getline(log, line))
    if (!line.empty()) last = line;
  const auto entry = nlohmann::json::parse(last);
  EXPECT_EQ(entry["step"], "marker add");
  EXPECT_EQ(entry["parameters"]["source"], "viewer");
  const forensics::VerifyReport report = forensics::verify_case(f.case_dir, false);
  EXPECT_TRUE(report.ok()) << (report.problems.empty() ? "" : report.problems[0].path + ": " +
                                                                  report.problems[0].detail);
}

// Issue 14: the viewer's saves go through the same transaction as the CLI's - a case that does
// not verify (a recorded file deleted, one planted) takes no marker: 409 with the finding,
// nothing written. Put back, the same request is saved (201) and the case verifies.
TEST(CaseApi, RefusesToAddToACaseThatDoesNotVerify) {
  Fixture f;
  CaseApi api(f.case_dir);
  const std::string mesh_json = R"({"triangles": 2, "inferred_triangles": 1})";
  fs::remove(f.case_dir / "mesh/mesh.json");
  write_text(f.case_dir / "planted.txt", "x");
  std::ifstream log_in(f.case_dir / "log.jsonl");
  const std::string log((std::istreambuf_iterator<char>(log_in)), {});
  const std::string body = R"({"position": [1, 2, 3], "label": "Casing", "snap": false})";
  ApiResponse r = api.handle("POST", "/api/markers", body);
  EXPECT_EQ(r.status, 409) << r.body;
  EXPECT_NE(r.body.find("mesh/mesh.json"), std::string::npos) << r.body;
  EXPECT_NE(r.body.find("planted.txt"), std::string::npos) << r.body;
  EXPECT_FALSE(fs::exists(f.case_dir / "evidence/markers.json"));
  std::ifstream after(f.case_dir / "log.jsonl");
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(after)), {}), log);
  write_text(f.case_dir / "mesh/mesh.json", mesh_json);
  fs::remove(f.case_dir / "planted.txt");
  r = api.handle("POST", "/api/markers", body);
  EXPECT_EQ(r.status, 201) << r.body;
  const forensics::VerifyReport report = forensics::verify_case(f.case_dir, false);
  EXPECT_TRUE(report.ok()) << (report.problems.empty() ? "" : report.problems[0].path);
}

}  // namespace
}  // namespace locard::viewer
