// Scenes compiled into the binary, so `locard scan-sim` runs anywhere with no data files.
// The text is a verbatim copy of data/scenes/<name>.json; a test checks the two agree.
#include <locard/sim/scene.hpp>

#include <locard/core/error.hpp>

#include <array>
#include <utility>

namespace locard::sim {
namespace {

// The reference paper's 3.84 m x 4 m bedroom with Table I's objects and measurements.
constexpr std::string_view kBedroom = R"scene({
  "name": "bedroom",
  "room": {"size": [3.84, 4.00, 2.60], "wall_color": [205, 195, 175],
           "floor_color": [120, 90, 60], "ceiling_color": [235, 235, 235],
           "texture": "noise", "texture_scale": 0.05},
  "objects": [
    {"name": "bed", "shape": "box", "size": [0.97, 2.04, 0.50], "center": [1.435, -0.90, 0.25],
     "color": [150, 30, 30], "texture": "checker", "texture_scale": 0.10},
    {"name": "headboard", "shape": "box", "size": [0.97, 0.05, 0.95],
     "center": [1.435, -1.945, 0.475], "color": [90, 60, 40], "texture": "noise"},
    {"name": "pillow", "shape": "box", "size": [0.60, 0.35, 0.12], "center": [1.435, -1.65, 0.56],
     "color": [230, 230, 240], "texture": "noise", "texture_scale": 0.02},
    {"name": "nightstand", "shape": "box", "size": [0.46, 0.40, 0.55],
     "center": [0.62, -1.80, 0.275], "color": [160, 120, 80], "texture": "noise"},
    {"name": "lamp", "shape": "cylinder", "radius": 0.08, "height": 0.35,
     "center": [0.62, -1.85, 0.725], "color": [240, 220, 150]},
    {"name": "electric socket", "shape": "box", "size": [0.08, 0.01, 0.08],
     "center": [0.0, -1.995, 0.39], "color": [245, 245, 245]},
    {"name": "table", "shape": "box", "size": [0.55, 0.85, 0.03], "center": [-1.645, -1.175, 0.735],
     "color": [110, 80, 50], "texture": "noise", "texture_scale": 0.03},
    {"name": "table leg 1", "shape": "box", "size": [0.04, 0.04, 0.72], "center": [-1.88, -1.56, 0.36],
     "color": [80, 60, 40]},
    {"name": "table leg 2", "shape": "box", "size": [0.04, 0.04, 0.72], "center": [-1.41, -1.56, 0.36],
     "color": [80, 60, 40]},
    {"name": "table leg 3", "shape": "box", "size": [0.04, 0.04, 0.72], "center": [-1.88, -0.79, 0.36],
     "color": [80, 60, 40]},
    {"name": "table leg 4", "shape": "box", "size": [0.04, 0.04, 0.72], "center": [-1.41, -0.79, 0.36],
     "color": [80, 60, 40]},
    {"name": "chair seat", "shape": "box", "size": [0.43, 0.43, 0.04], "center": [-1.055, -1.175, 0.43],
     "color": [60, 90, 140], "texture": "checker", "texture_scale": 0.05},
    {"name": "chair back", "shape": "box", "size": [0.04, 0.43, 0.45], "center": [-0.86, -1.175, 0.675],
     "color": [60, 90, 140], "texture": "noise"},
    {"name": "chair leg 1", "shape": "box", "size": [0.035, 0.035, 0.41],
     "center": [-1.25, -1.37, 0.205], "color": [40, 40, 45]},
    {"name": "chair leg 2", "shape": "box", "size": [0.035, 0.035, 0.41],
     "center": [-0.86, -1.37, 0.205], "color": [40, 40, 45]},
    {"name": "chair leg 3", "shape": "box", "size": [0.035, 0.035, 0.41],
     "center": [-1.25, -0.98, 0.205], "color": [40, 40, 45]},
    {"name": "chair leg 4", "shape": "box", "size": [0.035, 0.035, 0.41],
     "center": [-0.86, -0.98, 0.205], "color": [40, 40, 45]},
    {"name": "radiator", "shape": "box", "size": [0.08, 0.80, 0.36], "center": [1.88, 1.00, 0.33],
     "color": [240, 240, 240], "texture": "checker", "texture_scale": 0.04},
    {"name": "window", "shape": "box", "size": [0.03, 0.58, 1.10], "center": [1.905, 1.00, 1.55],
     "color": [150, 190, 220], "texture": "noise"},
    {"name": "cupboard", "shape": "box", "size": [0.80, 0.60, 2.00], "center": [0.60, 1.70, 1.00],
     "color": [170, 140, 100], "texture": "noise"},
    {"name": "cupboard door", "shape": "box", "size": [0.745, 0.02, 1.90], "center": [0.60, 1.39, 1.00],
     "color": [190, 160, 120], "texture": "noise", "texture_scale": 0.03},
    {"name": "cupboard handle", "shape": "box", "size": [0.02, 0.03, 0.15],
     "center": [0.93, 1.365, 1.00], "color": [200, 200, 205]},
    {"name": "shelf", "shape": "box", "size": [0.805, 0.30, 1.10], "center": [-0.6975, 1.85, 0.55],
     "color": [200, 170, 130], "texture": "noise"},
    {"name": "vase", "shape": "cylinder", "radius": 0.06, "height": 0.25,
     "center": [-0.95, 1.85, 1.225], "color": [40, 110, 80], "texture": "noise", "texture_scale": 0.02},
    {"name": "entrance door", "shape": "box", "size": [0.03, 0.99, 2.05],
     "center": [-1.905, 1.20, 1.025], "color": [235, 235, 225], "texture": "noise"},
    {"name": "door handle", "shape": "box", "size": [0.04, 0.12, 0.03], "center": [-1.87, 0.80, 1.05],
     "color": [180, 180, 185]},
    {"name": "suitcase", "shape": "box", "size": [0.45, 0.70, 0.25], "center": [-1.45, 0.0, 0.125],
     "yaw_deg": 10, "color": [10, 10, 12]}
  ],
  "measurements": [
    {"name": "Room width", "a": [-1.92, -0.30, 1.40], "b": [1.92, -0.30, 1.40]},
    {"name": "Nightstand", "a": [0.39, -1.60, 0.55], "b": [0.85, -1.60, 0.55]},
    {"name": "Radiator", "a": [1.84, 0.60, 0.15], "b": [1.84, 0.60, 0.51]},
    {"name": "Chair", "a": [-1.27, -1.39, 0.45], "b": [-1.27, -0.96, 0.45]},
    {"name": "Cupboard door", "a": [0.2275, 1.38, 1.00], "b": [0.9725, 1.38, 1.00]},
    {"name": "Entrance door", "a": [-1.89, 0.705, 1.00], "b": [-1.89, 1.695, 1.00]},
    {"name": "Shelf", "a": [-1.10, 1.70, 1.10], "b": [-0.295, 1.70, 1.10]},
    {"name": "Table", "a": [-1.37, -1.60, 0.75], "b": [-1.37, -0.75, 0.75]},
    {"name": "Window", "a": [1.89, 0.71, 1.00], "b": [1.89, 1.29, 1.00]},
    {"name": "Bed width", "a": [0.95, 0.12, 0.50], "b": [1.92, 0.12, 0.50]},
    {"name": "Bed length", "a": [0.95, -1.92, 0.50], "b": [0.95, 0.12, 0.50]},
    {"name": "Electric socket", "a": [0.0, -1.99, 0.0], "b": [0.0, -1.99, 0.39]}
  ],
  "scanner": {"model": "kinect_v2", "position": [0.0, 0.0, 1.20], "views": [50, 16],
              "pitch_deg": [-10, -50], "yaw_jitter_deg": 1.0, "position_jitter_m": 0.005, "seed": 1}
}
)scene";

constexpr std::array<std::pair<std::string_view, std::string_view>, 1> kBuiltins{{
    {"bedroom", kBedroom},
}};

}  // namespace

std::vector<std::string> builtin_scene_names() {
  std::vector<std::string> names;
  for (const auto& [name, text] : kBuiltins) names.emplace_back(name);
  return names;
}

std::string_view builtin_scene_json(std::string_view name) {
  for (const auto& [known, text] : kBuiltins)
    if (known == name) return text;
  std::string known_names;
  for (const auto& n : builtin_scene_names()) known_names += (known_names.empty() ? "" : ", ") + n;
  throw InputError("unknown built-in scene '" + std::string(name) + "' (built-in scenes: " +
                   known_names + ")");
}

Scene builtin_scene(std::string_view name) {
  const std::string_view text = builtin_scene_json(name);
  return parse_scene(text, "built-in:" + std::string(name));
}

}  // namespace locard::sim
