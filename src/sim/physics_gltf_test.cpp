// The simulation's animated GLB: re-imported by assimp with the expected nodes and animation
// channels, and its JSON chunk read directly for the labels and the sampler layout.
#include <locard/sim/physics_gltf.hpp>
#include <locard/sim/physics_world.hpp>

#include "physics_test_util.hpp"
#include "test_support.hpp"

#include <assimp/Importer.hpp>
#include <assimp/scene.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstring>
#include <functional>

namespace locard::sim {
namespace {

constexpr const char* kScenario = R"({
  "name": "glb", "duration": 1.0, "fps": 30,
  "objects": [{"name": "box", "shape": "box", "size": [0.2, 0.2, 0.2], "position": [0.3, 0.2, 0.8]},
              {"name": "ball", "shape": "sphere", "radius": 0.1, "position": [-0.3, 0.2, 0.8]}],
  "people": [{"name": "victim", "kind": "ragdoll", "position": [-0.5, 0.8, 0]},
             {"name": "walker", "kind": "avatar", "path": [{"time": 0, "position": [-0.6, -0.5, 0]},
                                                           {"time": 1, "position": [0.4, -0.5, 0]}]}],
  "projectiles": [{"name": "shot", "muzzle": [-1.5, 0, 1.5], "direction": [1, 0, 0], "speed": 300,
                   "fire_time": 0.25}]})";

TEST(PhysicsGltf, AssimpReimportsNodesAndAnimation) {
  const Scenario s = test::scenario_from(kScenario);
  const SimulationResult r = simulate(s, test::bedroom_mesh());
  // 2 objects + 11 ragdoll parts + 1 avatar + 1 projectile.
  ASSERT_EQ(r.tracks.size(), 15u);
  const std::filesystem::path path = locard::test::scratch_dir() / "animation.glb";
  write_simulation_glb(path, s, r);

  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path.string(), 0);
  ASSERT_NE(scene, nullptr) << importer.GetErrorString();
  // Root "simulation (illustrative)" with 15 bodies + 1 trail under it.
  const aiNode* root = scene->mRootNode;
  const aiNode* sim = root->FindNode("simulation (illustrative)");
  ASSERT_NE(sim, nullptr);
  EXPECT_EQ(sim->mNumChildren, 16u);
  for (const char* name : {"box", "ball", "victim/head", "victim/left shin", "walker", "shot", "shot trail"})
    EXPECT_NE(root->FindNode(name), nullptr) << name;
  ASSERT_EQ(scene->mNumAnimations, 1u);
  const aiAnimation* anim = scene->mAnimations[0];
  EXPECT_EQ(anim->mNumChannels, 16u) << "one channel set per animated node";
  // The ragdoll's head keys: one per frame at 30 Hz over 1 s.
  for (unsigned c = 0; c < anim->mNumChannels; ++c) {
    const aiNodeAnim* ch = anim->mChannels[c];
    if (std::string(ch->mNodeName.C_Str()) == "victim/head") {
      EXPECT_EQ(ch->mNumPositionKeys, 31u);
      EXPECT_EQ(ch->mNumRotationKeys, 31u);
    }
  }
  EXPECT_GE(scene->mNumMeshes, 16u);
}

TEST(PhysicsGltf, JsonChunkCarriesLabelsAndValidSamplers) {
  const Scenario s = test::scenario_from(kScenario);
  const SimulationResult r = simulate(s, test::bedroom_mesh());
  const std::vector<std::uint8_t> glb = simulation_glb(s, r);
  ASSERT_GE(glb.size(), 28u);
  auto u32 = [&](std::size_t at) {
    std::uint32_t v;
    std::memcpy(&v, glb.data() + at, 4);
    return v;
  };
  EXPECT_EQ(u32(0), 0x46546C67u);
  EXPECT_EQ(u32(4), 2u);
  EXPECT_EQ(u32(8), glb.size());
  const std::uint32_t json_length = u32(12);
  EXPECT_EQ(u32(16), 0x4E4F534Au);
  EXPECT_EQ(json_length % 4, 0u);
  const auto j = nlohmann::json::parse(glb.begin() + 20, glb.begin() + 20 + json_length);
  const std::uint32_t bin_length = u32(20 + json_length);
  EXPECT_EQ(u32(24 + json_length), 0x004E4942u);
  EXPECT_EQ(j["buffers"][0]["byteLength"], bin_length);
  EXPECT_EQ(j["asset"]["version"], "2.0");
  EXPECT_EQ(j["asset"]["extras"]["label"], "illustrative simulation, not measured data");
  for (const auto& node : j["nodes"]) EXPECT_EQ(node["extras"]["label"], "illustrative simulation, not measured data");
  // Every sampler input is increasing with min/max; outputs match inputs in count.
  const auto& acc = j["accessors"];
  const auto& anim = j["animations"][0];
  EXPECT_EQ(anim["channels"].size(), 15u * 2 + 2);  // T+R per body, scale for shot and its trail
  for (const auto& smp : anim["samplers"]) {
    const auto& in = acc[smp["input"].get<std::size_t>()];
    const auto& out = acc[smp["output"].get<std::size_t>()];
    EXPECT_TRUE(in.contains("min") && in.contains("max"));
    EXPECT_EQ(in["count"], out["count"]);
    EXPECT_LE(in["max"][0].get<double>(), 1.0 + 1e-6);
  }
  // Buffer views lie inside the binary chunk.
  for (const auto& v : j["bufferViews"])
    EXPECT_LE(v["byteOffset"].get<std::size_t>() + v["byteLength"].get<std::size_t>(), bin_length);
}

}  // namespace
}  // namespace locard::sim
