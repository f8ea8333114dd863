#pragma once
// The README's main job: simulate the paper's experiment (the `naraha` scenario with its fixed
// defaults), run the five methods of Table 2 on it, and report map error, ATE and speed beside
// the paper's numbers. Writes everything under one folder.
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "hazmap/core/property_icp_config.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "hazmap/pipeline/slam_method.hpp"

namespace hazmap {

/// The outputs of each demo run: `hazmap run`'s, without the reopenable map (the demo's runs are
/// compared, not entered again; naraha's keyframes alone are 63 MB per run).
OutputConfig demoRunOutputs();

struct DemoConfig {
  std::filesystem::path out_dir = "hazmap-demo";
  std::string scenario = "naraha";
  std::uint64_t seed = 1;
  std::size_t frames = 0;  ///< 0 = the whole route
  int threads = 0;         ///< 0 = all cores
  std::vector<SlamMethod> methods{kAllSlamMethods.begin(), kAllSlamMethods.end()};
  bool progress = true;    ///< progress bars (only ever drawn on a terminal)
  /// Besides the paper's set-up (ICP frame to frame from the wheel-odometry guess), also run the
  /// ICP methods with hazmap's default tracking (frame to a local map) into frame-to-map/.
  bool frame_to_map = true;
  /// Also simulate the thermal camera (640×512, 50° HFOV, looking forward), label the sequence
  /// from it (hazmap label) and run the property methods on those labels into camera-labels/.
  bool camera_labels = true;
  /// α and class search radii for every method (empty = the class table's).
  PropertyIcpConfig property_icp;
  /// `section.key=value` run settings applied to every method's SlamConfig (SlamConfig::applySetting).
  std::vector<std::string> settings;
  /// `section.key=value` simulator settings (e.g. odometry.slip_probability=0.3,
  /// robot.frame_distance=0.5) over the simulator's defaults; empty = the paper's experiment.
  std::vector<std::string> simulator_settings;
};

struct DemoRow {
  SlamMethod method = SlamMethod::PropertyIcpPgo;
  OdometryMode tracking = OdometryMode::FrameToFrame;
  double map_error_m = 0.0;    ///< the paper's Table 2 metric (mean point distance)
  double map_error_p95_m = 0.0;
  double ate_m = 0.0;          ///< APE rmse, SE(3)-aligned
  double frames_per_s = 0.0;   ///< SLAM only (no file output)
  std::size_t loops = 0;
  std::size_t fallbacks = 0;   ///< frames where ICP was rejected and odometry used
  /// Mean NEES of the pose graph's odometry and loop edges against the truth (eval/edge_nees;
  /// honest edges: 6), and how many edges of each kind.
  double nees_odometry = 0.0, nees_loop = 0.0;
  std::size_t odometry_edges = 0, loop_edges = 0;
};

struct DemoReport {
  std::vector<DemoRow> rows;      ///< the paper's set-up (frame-to-frame tracking)
  std::vector<DemoRow> map_rows;  ///< hazmap's frame-to-map tracking (empty if not run)
  /// Property ICP (+PGO), paper's set-up, with classes from the simulated thermal camera
  /// instead of the simulator's labels (empty if not run).
  std::vector<DemoRow> camera_rows;
  double camera_heat_precision = 0.0, camera_heat_recall = 0.0;  ///< inside the camera's view
  std::size_t frames = 0;
  double route_length_m = 0.0;
  double simulate_seconds = 0.0;
  double total_seconds = 0.0;
};

/// Runs the demo, printing progress and the table to `out`. Writes
/// <out_dir>/sequence/ (the simulated sequence), <out_dir>/<method>/ (one `hazmap run` output
/// folder per method, the paper's set-up), <out_dir>/maps_side_by_side.png, and with
/// frame_to_map <out_dir>/frame-to-map/<method>/ and maps_side_by_side_frame_to_map.png;
/// <out_dir>/table2.json holds per method map_error_m, ate_m, frames_per_s (paper set-up) and
/// the same under "frame_to_map".
DemoReport runDemo(const DemoConfig& config, std::ostream& out);

/// The camera-label rows: labels `sequence_dir` from its cameras/thermal into
/// <out_dir>/camera-labels/sequence and runs property ICP and property ICP+PGO (frame to frame)
/// on it into <out_dir>/camera-labels/<method>/. Fills report.camera_rows and the precision.
void runCameraLabelRows(const DemoConfig& config, const std::filesystem::path& sequence_dir,
                        DemoReport& report, std::ostream& out);

/// The single-seed table2.json object (what runDemo writes), as JSON text.
std::string table2Json(const DemoReport& report);

/// The table as text (paper's numbers beside ours).
std::string formatTable2(const DemoReport& report);

}  // namespace hazmap
