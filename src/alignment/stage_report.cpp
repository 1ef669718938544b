// Stage report: errors after SVD, ICP and loop closure (stage_report.hpp), as JSON and SVG.
#include <locard/alignment/stage_report.hpp>

#include <locard/alignment/trajectory_eval.hpp>
#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/io/matrix_json.hpp>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

namespace locard {
namespace {

const std::optional<Isometry3d>& stage_pose(const FrameAlignment& f, int stage) {
  if (stage == 0) return f.T_world_camera_svd;
  if (stage == 1) return f.T_world_camera_icp;
  return f.T_world_camera_final;
}

nlohmann::json optional_json(const std::optional<double>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else out += c;
  }
  return out;
}

// A "nice" axis maximum and tick step for [0, v].
std::pair<double, double> nice_axis(double v) {
  if (!(v > 0.0)) return {1.0, 0.2};
  const double p = std::pow(10.0, std::floor(std::log10(v)));
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (m * p >= v) return {m * p, m * p / 5.0};
  return {10.0 * p, 2.0 * p};
}

}  // namespace

std::string_view to_string(AlignmentStage stage) {
  switch (stage) {
    case AlignmentStage::Svd: return "svd";
    case AlignmentStage::Icp: return "icp";
    case AlignmentStage::LoopClosure: return "loop_closure";
  }
  return "unknown";
}

StageReport make_stage_report(const AlignmentResult& result,
                              const std::vector<std::optional<Isometry3d>>& ground_truth) {
  if (ground_truth.size() != result.frames.size())
    throw InputError(fmt::format("stage report: {} ground-truth entries for {} frames",
                                 ground_truth.size(), result.frames.size()));
  StageReport report;
  const FrameAlignment* first = nullptr;
  std::size_t first_k = 0;
  for (std::size_t k = 0; k < result.frames.size(); ++k) {
    const FrameAlignment& f = result.frames[k];
    if (f.status == FrameStatus::Registered && f.piece == 0 && ground_truth[k]) {
      first = &f;
      first_k = k;
      break;
    }
  }
  report.has_ground_truth = first != nullptr;
  if (!first) return report;
  const Isometry3d G0_inv = ground_truth[first_k]->inverse();
  Trajectory gt_traj, est_traj[3];
  for (std::size_t k = 0; k < result.frames.size(); ++k) {
    const FrameAlignment& f = result.frames[k];
    if (f.status != FrameStatus::Registered || f.piece != 0 || !ground_truth[k]) continue;
    StageViewError v;
    v.frame_index = f.frame_index;
    const Isometry3d G = G0_inv * *ground_truth[k];
    gt_traj.push_back({f.frame_index, f.timestamp, *ground_truth[k]});
    for (int s = 0; s < 3; ++s) {
      // The first view is the origin of every stage (its SVD pose is the identity by
      // definition: it is not registered to anything).
      std::optional<Isometry3d> T0 = stage_pose(*first, s);
      std::optional<Isometry3d> T = stage_pose(f, s);
      if (s == 0) {
        T0 = first->T_world_camera_icp;
        if (&f == first) T = T0;
      }
      if (!T0 || !T) continue;
      const Isometry3d E = T0->inverse() * *T;
      v.translation_m[s] = translation_difference_m(G, E);
      v.rotation_deg[s] = rotation_difference_deg(G, E);
      est_traj[s].push_back({f.frame_index, f.timestamp, *T});
    }
    report.views.push_back(v);
  }
  for (int s = 0; s < 3; ++s) {
    StageSummary& sum = report.summary[s];
    for (const StageViewError& v : report.views) {
      if (!v.translation_m[s]) continue;
      ++sum.views;
      sum.mean_translation_m += *v.translation_m[s];
      sum.max_translation_m = std::max(sum.max_translation_m, *v.translation_m[s]);
      sum.mean_rotation_deg += *v.rotation_deg[s];
      sum.max_rotation_deg = std::max(sum.max_rotation_deg, *v.rotation_deg[s]);
    }
    if (sum.views) {
      sum.mean_translation_m /= static_cast<double>(sum.views);
      sum.mean_rotation_deg /= static_cast<double>(sum.views);
    }
    if (est_traj[s].size() >= 3) {
      AssociationOptions a;
      a.match_by_frame_index = true;
      try {
        sum.ate_rmse_m = absolute_trajectory_error(gt_traj, est_traj[s], a).translation.rmse;
      } catch (const InputError&) {
        // degenerate (collinear) camera positions: no ATE for this stage
      }
    }
  }
  return report;
}

StageReport make_stage_report(const AlignmentResult& result, const RgbdSequence& sequence) {
  std::vector<std::optional<Isometry3d>> gt;
  for (const FrameAlignment& f : result.frames)
    gt.push_back(sequence.frames.at(f.sequence_index).T_world_camera);
  return make_stage_report(result, gt);
}

void write_stage_report_json(const std::filesystem::path& path, const AlignmentResult& result,
                             const StageReport& report) {
  nlohmann::json j;
  j["mode"] = std::string(to_string(result.options.mode));
  j["voxel_size_m"] = result.options.voxel_size;
  j["seed"] = result.options.seed;
  j["has_ground_truth"] = report.has_ground_truth;
  j["pieces"] = result.pieces;
  nlohmann::json stages = nlohmann::json::object();
  for (int s = 0; s < 3; ++s) {
    const StageSummary& sum = report.summary[s];
    stages[std::string(to_string(static_cast<AlignmentStage>(s)))] = {
        {"views", sum.views},
        {"mean_translation_m", sum.mean_translation_m},
        {"max_translation_m", sum.max_translation_m},
        {"mean_rotation_deg", sum.mean_rotation_deg},
        {"max_rotation_deg", sum.max_rotation_deg},
        {"ate_rmse_m", optional_json(sum.ate_rmse_m)}};
  }
  j["stages"] = stages;
  nlohmann::json views = nlohmann::json::array();
  for (const StageViewError& v : report.views) {
    nlohmann::json e = {{"frame_index", v.frame_index}};
    for (int s = 0; s < 3; ++s) {
      const std::string name(to_string(static_cast<AlignmentStage>(s)));
      e[name + "_translation_m"] = optional_json(v.translation_m[s]);
      e[name + "_rotation_deg"] = optional_json(v.rotation_deg[s]);
    }
    views.push_back(e);
  }
  j["views"] = views;
  nlohmann::json frames = nlohmann::json::array();
  for (const FrameAlignment& f : result.frames) {
    nlohmann::json e = {{"frame_index", f.frame_index},
                        {"timestamp", f.timestamp},
                        {"status", std::string(to_string(f.status))},
                        {"points", f.points},
                        {"fitness", f.fitness},
                        {"inlier_rmse_m", f.inlier_rmse}};
    if (f.status == FrameStatus::Registered) {
      e["piece"] = f.piece;
      e["initialisation"] = f.initialisation;
      // 3x4: the pose without its constant last row (bench/room_robustness.py reads it so).
      if (f.T_world_camera_final)
        e["T_world_camera"] = matrix_json(f.T_world_camera_final->matrix().topRows<3>());
      const ViewCheck& c = f.check;
      e["verified"] = f.trusted();
      e["check"] = {{"checked", c.checked},        {"verified", c.verified},
                    {"confidence", c.confidence},  {"overlap", c.overlap},
                    {"residual_m", c.residual_m},  {"correction_m", c.correction_m},
                    {"correction_deg", c.correction_deg}, {"free_space", c.free_space},
                    {"constraint", c.constraint},  {"reason", c.reason}};
      if (std::isfinite(c.off_axis_deg)) e["check"]["off_axis_deg"] = c.off_axis_deg;
      if (c.fixed_by_color) e["check"]["fixed_by_color"] = true;
      e["check"]["slide_constraint"] = c.slide_constraint;
      if (std::isfinite(c.tripod_play_m)) e["check"]["tripod_play_m"] = c.tripod_play_m;
      if (std::isfinite(c.tripod_residual_m))
        e["check"]["tripod_residual_m"] = c.tripod_residual_m;
    } else {
      e["reason"] = f.reason;
    }
    frames.push_back(e);
  }
  j["frames"] = frames;
  j["unregistered_frames"] = result.unregistered_frame_indices();
  j["flagged_frames"] = result.flagged_frame_indices();
  j["verified_share"] = result.trusted_share();
  j["min_verified_share"] = result.options.min_verified_share;
  nlohmann::json loops = nlohmann::json::array();
  for (const LoopCandidate& c : result.loops) {
    const auto& fs = result.frames;
    nlohmann::json e = {{"source_frame", fs[c.source].frame_index},
                        {"target_frame", fs[c.target].frame_index},
                        {"found_by", std::string(to_string(c.found_by))},
                        {"accepted", c.accepted},
                        {"fitness", c.fitness},
                        {"inlier_rmse_m", c.inlier_rmse}};
    if (c.accepted || c.chi2_before > 0.0) {
      e["chi2_before"] = c.chi2_before;
      e["chi2_after"] = c.chi2_after;
      e["line_process_weight"] = c.confidence;
    }
    if (!c.accepted) e["reason"] = c.reason;
    loops.push_back(e);
  }
  j["loop_closures"] = loops;
  const PoseGraphResult& pg = result.pose_graph;
  j["pose_graph"] = {{"success", pg.success},
                     {"nodes", result.graph.nodes.size()},
                     {"edges", result.graph.edges.size()},
                     {"initial_cost", pg.initial_cost},
                     {"final_cost", pg.final_cost},
                     {"mu", pg.mu},
                     {"solves", pg.solves},
                     {"iterations", pg.iterations},
                     {"max_odometry_bend_deg", pg.max_odometry_bend_deg},
                     {"max_odometry_bend_m", pg.max_odometry_bend_m},
                     {"rejected_edges", pg.rejected.size()}};
  const JointRefinement& jr = result.refinement;
  j["joint_refinement"] = {{"run", jr.ran},
                           {"pairs", jr.pairs},
                           {"iterations", jr.iterations},
                           {"correspondences", jr.correspondences},
                           {"views_held", jr.views_held},
                           {"max_change_m", jr.max_change_m},
                           {"max_change_deg", jr.max_change_deg},
                           {"undone", jr.undone}};
  const AlignmentTimings& t = result.timings;
  j["timings_s"] = {{"prepare", t.prepare_s},
                    {"register", t.register_s},
                    {"loop_closure", t.loop_closure_s},
                    {"pose_graph", t.pose_graph_s},
                    {"joint_refinement", t.refinement_s},
                    {"verification", t.verification_s},
                    {"total", t.total_s}};
  AtomicFile file(path, false);
  file.stream() << j.dump(2) << '\n';
  file.commit();
}

std::string stage_report_svg(const AlignmentResult& result, const StageReport& report) {
  constexpr double W = 720, H = 420, L = 70, R = 170, T = 40, B = 50;
  const double pw = W - L - R, ph = H - T - B;
  struct Series {
    std::string label;
    std::string color;
    std::vector<std::pair<double, double>> points;  // (x, y in mm)
  };
  std::vector<Series> series;
  std::string title, xlabel, ylabel;
  if (report.has_ground_truth) {
    title = "Cumulative error per view after each stage";
    xlabel = "view (registered frames, in order)";
    ylabel = "translation error (mm)";
    const char* labels[3] = {"initial pose", "after ICP", "after loop closure"};
    const char* colors[3] = {"#d62728", "#1f77b4", "#2ca02c"};
    for (int s = 0; s < 3; ++s) {
      Series se{labels[s], colors[s], {}};
      for (std::size_t k = 0; k < report.views.size(); ++k)
        if (report.views[k].translation_m[s])
          se.points.emplace_back(static_cast<double>(k), 1000.0 * *report.views[k].translation_m[s]);
      series.push_back(std::move(se));
    }
  } else {
    title = "Loop closures: inlier RMSE of the verified ICP";
    xlabel = "loop candidate";
    ylabel = "inlier RMSE (mm)";
    Series acc{"accepted", "#2ca02c", {}}, rej{"rejected", "#d62728", {}};
    for (std::size_t k = 0; k < result.loops.size(); ++k)
      (result.loops[k].accepted ? acc : rej)
          .points.emplace_back(static_cast<double>(k), 1000.0 * result.loops[k].inlier_rmse);
    series = {acc, rej};
  }
  double xmax = 1.0, ymax = 0.0;
  for (const Series& s : series)
    for (const auto& [x, y] : s.points) {
      xmax = std::max(xmax, x);
      ymax = std::max(ymax, y);
    }
  const auto [ytop, ystep] = nice_axis(ymax);
  const auto [xtop, xstep] = nice_axis(xmax);
  const auto X = [&](double x) { return L + pw * x / xtop; };
  const auto Y = [&](double y) { return T + ph * (1.0 - y / ytop); };
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} "
      "{1}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" "
      "fill=\"white\"/>\n<text x=\"{2}\" y=\"22\" font-size=\"15\">{3}</text>\n",
      W, H, L, escape(title));
  for (double y = 0.0; y <= ytop + 1e-9 * ytop; y += ystep)
    svg += fmt::format(
        "<line x1=\"{0}\" x2=\"{1}\" y1=\"{2:.2f}\" y2=\"{2:.2f}\" stroke=\"#ddd\"/><text x=\"{3}\" "
        "y=\"{4:.2f}\" text-anchor=\"end\">{5:g}</text>\n",
        L, L + pw, Y(y), L - 6, Y(y) + 4, y);
  for (double x = 0.0; x <= xtop + 1e-9 * xtop; x += xstep)
    svg += fmt::format(
        "<line x1=\"{0:.2f}\" x2=\"{0:.2f}\" y1=\"{1}\" y2=\"{2}\" stroke=\"#ddd\"/><text "
        "x=\"{0:.2f}\" y=\"{3}\" text-anchor=\"middle\">{4:g}</text>\n",
        X(x), T, T + ph, T + ph + 16, x);
  svg += fmt::format(
      "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n"
      "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n"
      "<text transform=\"translate(18 {}) rotate(-90)\" text-anchor=\"middle\">{}</text>\n",
      L, T, pw, ph, L + pw / 2, H - 12, escape(xlabel), T + ph / 2, escape(ylabel));
  for (std::size_t i = 0; i < series.size(); ++i) {
    const Series& s = series[i];
    if (report.has_ground_truth && s.points.size() >= 2) {
      std::string pts;
      for (const auto& [x, y] : s.points) pts += fmt::format("{:.2f},{:.2f} ", X(x), Y(y));
      svg += fmt::format("<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"1.8\" "
                         "points=\"{}\"/>\n",
                         s.color, pts);
    }
    for (const auto& [x, y] : s.points)
      svg += fmt::format("<circle cx=\"{:.2f}\" cy=\"{:.2f}\" r=\"2.5\" fill=\"{}\"/>\n", X(x), Y(y),
                         s.color);
    // Two lines an entry, the ATE under the label: one line overran the right margin.
    const double ly = T + 20 + 34 * static_cast<double>(i);
    std::string ate;
    if (report.has_ground_truth && report.summary[i].ate_rmse_m)
      ate = fmt::format("ATE {:.1f} mm", 1000.0 * *report.summary[i].ate_rmse_m);
    svg += fmt::format(
        "<line x1=\"{0}\" x2=\"{1}\" y1=\"{2:.2f}\" y2=\"{2:.2f}\" stroke=\"{3}\" "
        "stroke-width=\"3\"/><text x=\"{4}\" y=\"{5:.2f}\" font-size=\"11\">{6}</text>"
        "<text x=\"{4}\" y=\"{7:.2f}\" font-size=\"11\">{8}</text>\n",
        L + pw + 10, L + pw + 28, ly, s.color, L + pw + 32, ly + 4, escape(s.label), ly + 17,
        escape(ate));
  }
  svg += "</svg>\n";
  return svg;
}

void write_stage_report_svg(const std::filesystem::path& path, const AlignmentResult& result,
                            const StageReport& report) {
  AtomicFile file(path, false);
  file.stream() << stage_report_svg(result, report);
  file.commit();
}

}  // namespace locard
