#pragma once
// The stages `reconstruct` shares between its inputs (RGB-D sequences in reconstruct.cpp, range
// scans in reconstruct_scans.cpp): helpers, the measurement and report stages, the begin /
// failed / complete bracket and the E57 export of the registered views (case_e57.cpp).

#include <locard/core/point_cloud.hpp>
#include <locard/core/pose.hpp>
#include <locard/forensics/case_folder.hpp>
#include <locard/forensics/measurement.hpp>
#include <locard/forensics/reconstruct.hpp>
#include <locard/io/mesh_export.hpp>
#include <locard/io/range_scans.hpp>
#include <locard/io/rgbd_sequence.hpp>
#include <locard/io/matrix_json.hpp>

#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace locard::forensics::detail {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t);
void write_json(const std::filesystem::path& path, const nlohmann::json& j);
void write_text(const std::filesystem::path& path, const std::string& text);
nlohmann::json parameters_json(const ReconstructParameters& p);
std::string software_version();
// Every file under `root` (or `root` itself when it is a file), hashed in parallel, sorted.
std::vector<FileRecord> hash_inputs(const std::filesystem::path& root,
                                    const ProgressCallback& progress);

// StageCallbacks with the empty cases handled.
struct StageHooks {
  const StageCallbacks& cb;
  ProgressCallback begin(const std::string& stage, std::size_t total) const {
    return cb.begin ? cb.begin(stage, total) : ProgressCallback{};
  }
  void end(const std::string& stage) const {
    if (cb.end) cb.end(stage);
  }
  void note(const std::string& message) const {
    if (cb.log) cb.log(message);
  }
};

// mesh/mesh.<format> for each format (OBJ and FBX with `up` up), and mesh/mesh.ply always
// (measurements need it); the relative paths written.
std::vector<std::filesystem::path> write_mesh_files(CaseFolder& folder, const TriangleMesh& mesh,
                                                    const std::vector<MeshFormat>& formats,
                                                    UpAxis up);

// ---- measure: the reference (tape) distances against the case model -> measurements/table.*
void run_measure_stage(CaseFolder& folder, const std::filesystem::path& reference,
                       const std::vector<ReferenceMeasurement>& refs,
                       const ReconstructParameters& P, const StageHooks& hooks,
                       ReconstructSummary& summary);
// ---- report -> report/report.html (+ .pdf)
void run_report_stage(CaseFolder& folder, const std::string& title, const ReconstructParameters& P,
                      const StageHooks& hooks, ReconstructSummary& summary);

// Creates the case folder and runs `stages` between the "begin" and "complete" log lines
// ("failed" with the error when a stage throws, then rethrown).
ReconstructSummary run_bracketed(const std::filesystem::path& input_root,
                                 const std::filesystem::path& case_dir, bool force,
                                 const std::function<void(CaseFolder&, ReconstructSummary&)>& stages);

// ---- export e57: the registered views as one E57 scan each, in the view's own frame with its
// registered pose -> cloud/registered.e57 (logged as the step "export e57").
struct E57View {
  std::string name;
  PointCloud cloud;  // in the view's frame (camera or scanner)
  Isometry3d T_world_view = Isometry3d::Identity();
};
void write_views_e57(CaseFolder& folder, const std::vector<E57View>& views,
                     const std::vector<std::string>& inputs, const std::string& parameters_json,
                     ReconstructSummary& summary);
// The verified views of an RGB-D case: depth to points in the camera frame (every `stride`-th
// pixel, thinned to `voxel_m`), pose = the view's registered pose (views without one skipped).
std::vector<E57View> rgbd_e57_views(const RgbdSequence& sequence,
                                    const std::vector<std::optional<Isometry3d>>& poses,
                                    const ReconstructParameters& P);

// The range-scan path of reconstruct_case (reconstruct_scans.cpp).
ReconstructSummary reconstruct_scan_case(const RangeScanSet& set,
                                         const std::filesystem::path& case_dir,
                                         const ReconstructParameters& P, bool force,
                                         const StageCallbacks& cb);

}  // namespace locard::forensics::detail
