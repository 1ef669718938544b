// Time to run a 5-second physics scenario on the simulated bedroom's mesh at 240 steps/s
// (1200 steps): a thrown box, a dropped ball, a collapsing 11-capsule ragdoll, a walking
// avatar and two shots - everything `locard simulate` steps, without the file output.
// Reported as wall time per scenario and physics steps per second. No peer: Bullet is the
// engine, and the figure to watch is that a scenario takes well under a second.
#include <locard/sim/physics_scenario.hpp>
#include <locard/sim/physics_world.hpp>
#include <locard/sim/scene.hpp>
#include <locard/sim/scene_mesh.hpp>

#include <benchmark/benchmark.h>

namespace {

using namespace locard::sim;

constexpr const char* kScenario = R"({
  "name": "bench", "duration": 5.0,
  "objects": [{"name": "box", "shape": "box", "size": [0.2, 0.15, 0.1], "position": [-1.3, -0.9, 0.81],
               "velocity": [1.2, 0.4, 0.0]},
              {"name": "ball", "shape": "sphere", "radius": 0.11, "position": [1.3, -0.4, 1.6]}],
  "people": [{"name": "victim", "kind": "ragdoll", "position": [0.2, -0.3, 0.0], "yaw_deg": 90,
              "velocity": [0.0, -1.0, 0.0]},
             {"name": "walker", "kind": "avatar", "path": [{"time": 0, "position": [-1.4, 1.0, 0]},
                                                           {"time": 3.5, "position": [1.2, 0.6, 0]}]}],
  "projectiles": [{"name": "shot 1", "muzzle": [-1.5, 0.5, 1.4], "direction": [2.935, -2.4, -0.6], "speed": 360},
                  {"name": "shot 2", "muzzle": [-1.5, 0.0, 1.5], "direction": [1, 0, 0], "speed": 360,
                   "fire_time": 2.0}]})";

void BM_SimulateBedroomScenario5s(benchmark::State& state) {
  const locard::TriangleMesh mesh = build_scene_mesh(builtin_scene("bedroom")).mesh;
  const Scenario scenario = parse_scenario(kScenario, "bench.json");
  std::size_t steps = 0;
  for (auto _ : state) {
    SimulationResult r = simulate(scenario, mesh);
    steps += r.steps;
    benchmark::DoNotOptimize(r.events.data());
  }
  state.counters["steps/s"] = benchmark::Counter(static_cast<double>(steps), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SimulateBedroomScenario5s)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
