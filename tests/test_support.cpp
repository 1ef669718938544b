#include "test_support.hpp"

#include <locard/core/pose.hpp>

#include <Eigen/SVD>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

namespace locard::test {

std::filesystem::path shared_data() { return LOCARD_SHARED_DATA; }

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

}  // namespace locard::test
