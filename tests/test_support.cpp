#include "test_support.hpp"

#include <locard/core/pose.hpp>

#include <Eigen/SVD>
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <algorithm>
#include <sstream>
#include <array>
#include <cstdio>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

namespace locard::test {

std::filesystem::path shared_data() { return LOCARD_SHARED_DATA; }

namespace {

// Scratch folders are removed as soon as what made them passed: a test's at its end, a suite's
// (made in SetUpTestSuite) at the suite's end, one made outside both (a cached scene) when the
// process ends. A failure keeps its folder, named on stderr, to look at. Without this the suite
// leaves gigabytes of reconstructions in the temp folder, and a CI disk fills before ASan links.
enum class ScratchScope { test, suite, process };

struct ScratchFolder {
  std::filesystem::path path;
  ScratchScope scope;
};

std::vector<ScratchFolder>& scratch_folders() {
  static std::vector<ScratchFolder> folders;
  return folders;
}

void release_scratch(ScratchScope scope, bool passed) {
  auto& folders = scratch_folders();
  auto keep = [&](const ScratchFolder& f) {
    if (f.scope != scope) return true;
    if (passed) {
      std::error_code ec;
      std::filesystem::remove_all(f.path, ec);
    } else {
      std::fprintf(stderr, "scratch folder kept: %s\n", f.path.c_str());
    }
    return false;
  };
  folders.erase(std::remove_if(folders.begin(), folders.end(), [&](const auto& f) { return !keep(f); }),
                folders.end());
}

class ScratchCleaner : public ::testing::EmptyTestEventListener {
  void OnTestEnd(const ::testing::TestInfo& info) override {
    release_scratch(ScratchScope::test, !info.result()->Failed());
  }
  void OnTestSuiteEnd(const ::testing::TestSuite& suite) override {
    release_scratch(ScratchScope::suite, !suite.ad_hoc_test_result().Failed() && suite.failed_test_count() == 0);
  }
  void OnTestProgramEnd(const ::testing::UnitTest& unit) override {
    release_scratch(ScratchScope::process, unit.Passed());
  }
};

void track_scratch(const std::filesystem::path& dir, ScratchScope scope) {
  static const bool installed = [] {  // the listener list owns it
    ::testing::UnitTest::GetInstance()->listeners().Append(new ScratchCleaner);
    return true;
  }();
  (void)installed;
  scratch_folders().push_back({dir, scope});
}

}  // namespace

std::filesystem::path scratch_dir() {
  // ctest runs the tests of one executable in parallel processes, and SetUpTestSuite has no
  // current test: the suite name plus the process id keeps every caller's folder its own.
  const auto* unit = ::testing::UnitTest::GetInstance();
  const auto* info = unit->current_test_info();
  const auto* suite = unit->current_test_suite();
  std::string name = info    ? std::string(info->test_suite_name()) + "." + info->name()
                     : suite ? std::string(suite->name()) + ".suite"
                             : std::string("scratch");
  name += "." + std::to_string(::getpid());
  std::replace(name.begin(), name.end(), '/', '_');
  const auto dir = std::filesystem::temp_directory_path() / "locard-tests" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  track_scratch(dir, info ? ScratchScope::test : suite ? ScratchScope::suite : ScratchScope::process);
  return dir;
}

std::filesystem::path process_scratch_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "locard-tests" /
                   (name + "." + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  track_scratch(dir, ScratchScope::process);
  return dir;
}

CommandResult run_cli(const std::string& arguments) {
  const std::string command = std::string("'") + LOCARD_CLI_PATH + "' " + arguments + " 2>&1";
  CommandResult result;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buffer{};
  std::size_t n;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

std::string list_folder(const std::filesystem::path& folder) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(folder)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  std::string out;
  for (const auto& n : names) out += n + "\n";
  return out;
}

std::vector<std::pair<double, double>> errors_after_fit(const std::vector<Eigen::Isometry3d>& estimate,
                                                        const std::vector<Eigen::Isometry3d>& truth) {
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < estimate.size(); ++i) M += truth[i].linear() * estimate[i].linear().transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant();
  const Eigen::Matrix3d R = svd.matrixU() * D * svd.matrixV().transpose();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < estimate.size(); ++i) t += truth[i].translation() - R * estimate[i].translation();
  if (!estimate.empty()) t /= static_cast<double>(estimate.size());
  std::vector<std::pair<double, double>> errors;
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    Eigen::Isometry3d fitted = estimate[i];
    fitted.linear() = R * fitted.linear();
    fitted.translation() = R * fitted.translation() + t;
    errors.emplace_back(rotation_difference_deg(fitted, truth[i]),
                        translation_difference_m(fitted, truth[i]));
  }
  return errors;
}

// One request over a fresh connection to 127.0.0.1:port; HTTP/1.0, so the server closes the
// connection after answering and the reply is everything read.
Reply http_request(std::uint16_t port, const std::string& method, const std::string& target,
                   const std::map<std::string, std::string>& headers,
                   const std::string& body) {
  Reply reply;
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) {
    ADD_FAILURE() << "socket() failed";
    return reply;
  }
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(port);
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    ::close(fd);
    ADD_FAILURE() << "cannot connect to 127.0.0.1:" << port;
    return reply;
  }
  std::ostringstream out;
  out << method << " " << target << " HTTP/1.0\r\n";
  if (!headers.count("Host")) out << "Host: 127.0.0.1\r\n";
  for (const auto& [k, v] : headers) out << k << ": " << v << "\r\n";
  if (method == "POST")
    out << "Content-Type: application/json\r\nContent-Length: " << body.size() << "\r\n";
  out << "\r\n" << body;
  const std::string text = out.str();
  for (std::size_t sent = 0; sent < text.size();) {
    const ssize_t n = ::send(fd, text.data() + sent, text.size() - sent, 0);
    if (n <= 0) break;
    sent += static_cast<std::size_t>(n);
  }
  std::string raw;
  char buffer[4096];
  for (ssize_t n; (n = ::recv(fd, buffer, sizeof buffer, 0)) > 0;)
    raw.append(buffer, static_cast<std::size_t>(n));
  ::close(fd);
  const std::size_t end = raw.find("\r\n\r\n");
  if (end == std::string::npos) {
    ADD_FAILURE() << "malformed reply: " << raw;
    return reply;
  }
  std::istringstream head(raw.substr(0, end));
  std::string line, version;
  std::getline(head, line);
  std::istringstream(line) >> version >> reply.status;
  while (std::getline(head, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string name = line.substr(0, colon);
    for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const std::size_t value = line.find_first_not_of(' ', colon + 1);
    reply.headers[name] = value == std::string::npos ? "" : line.substr(value);
  }
  reply.body = raw.substr(end + 4);
  return reply;
}


}  // namespace locard::test
