#pragma once
// The peer side of bench/harness/peer_harness.hpp for C++ peers (PCL): read the task file,
// prepare untimed, run `warmup` untimed and `repeats` timed passes, print one JSON line
// {"peer", "kernel", "seconds", "cpu_seconds", "output"}.
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <string>

namespace locard_pcl {

// prepare(task) returns the timed pass, a closure over what it prepared.
using Pass = std::function<nlohmann::json()>;
using Prepare = std::function<Pass(const nlohmann::json& task)>;

inline int serve(int argc, char** argv, const std::string& version,
                 const std::map<std::string, Prepare>& kernels) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s TASK.json (written by Locard's benchmark harness)\n", argv[0]);
    return 2;
  }
  std::ifstream in(argv[argc - 1]);
  const nlohmann::json task = nlohmann::json::parse(in, nullptr, false);
  if (task.is_discarded()) {
    std::fprintf(stderr, "%s: not a JSON task file\n", argv[argc - 1]);
    return 2;
  }
  const std::string name = task.value("kernel", "");
  const auto kernel = kernels.find(name);
  if (kernel == kernels.end()) {
    std::fprintf(stderr, "%s: no kernel '%s'\n", argv[0], name.c_str());
    return 2;
  }
  const Pass pass = kernel->second(task);
  for (int i = 0; i < task.value("warmup", 0); ++i) pass();
  nlohmann::json wall = nlohmann::json::array(), cpu = nlohmann::json::array(), output;
  for (int i = 0; i < task.value("repeats", 1); ++i) {
    const std::clock_t cpu_start = std::clock();  // process CPU, all threads
    const auto start = std::chrono::steady_clock::now();
    output = pass();
    wall.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    cpu.push_back(static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC);
  }
  const nlohmann::json answer = {{"peer", version}, {"kernel", name}, {"seconds", wall},
                                 {"cpu_seconds", cpu}, {"output", output}};
  std::printf("%s\n", answer.dump().c_str());
  return 0;
}

}  // namespace locard_pcl
