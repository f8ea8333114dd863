// The demo's camera-label rows: property ICP (+PGO) on classes from the simulated thermal and
// NIR cameras (hazmap label) instead of the simulator's labels, to see what a real robot — whose
// labels come from a camera with a 50° view, not from ground truth — would get.
#include <fmt/format.h>

#include <ostream>

#include "hazmap/demo/demo.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "hazmap/properties/label_sequence.hpp"

namespace hazmap {

void runCameraLabelRows(const DemoConfig& config, const std::filesystem::path& sequence_dir, DemoReport& report,
                        std::ostream& out) {
  const std::filesystem::path dir = config.out_dir / "camera-labels";
  std::filesystem::create_directories(dir);
  LabelOptions options;
  options.cameras = {sequence_dir / "cameras" / "thermal" / "camera.yaml", sequence_dir / "cameras" / "nir" / "camera.yaml"};
  options.overwrite = true;
  const LabelReport labels = labelSequence(sequence_dir, dir / "sequence", options);
  if (const auto it = labels.classes.find("heat"); it != labels.classes.end()) {
    report.camera_heat_precision = it->second.precision().value_or(0.0);
    report.camera_heat_recall = it->second.recall().value_or(0.0);
  }
  double water_precision = 0.0, water_recall = 0.0;
  if (const auto it = labels.classes.find("water"); it != labels.classes.end()) {
    water_precision = it->second.precision().value_or(0.0);
    water_recall = it->second.recall().value_or(0.0);
  }
  const auto percent = [&](std::size_t n) { return labels.points ? 100.0 * double(n) / double(labels.points) : 0.0; };
  out << fmt::format("  thermal + NIR camera labels: heat precision {:.3f}, recall {:.3f}; water precision {:.3f}, "
                     "recall {:.3f} in view; {:.1f} % of points observed, {:.1f} % valued after view fusion\n",
                     report.camera_heat_precision, report.camera_heat_recall, water_precision, water_recall,
                     percent(labels.projection.observed), percent(labels.valued));
  const Sequence sequence = Sequence::open(dir / "sequence");
  for (SlamMethod method : {SlamMethod::PropertyIcp, SlamMethod::PropertyIcpPgo}) {
    SlamConfig slam = SlamConfig::forMethod(method);
    slam.property_icp = config.property_icp;  // --mismatch-penalty, --class-radius, --set reach these rows too
    for (const auto& setting : config.settings) slam.applySetting(setting);
    slam.odometry.mode = OdometryMode::FrameToFrame;
    slam.threads = config.threads;
    const SlamResult result = runSlam(sequence, slam);
    const RunSummary summary = writeRunOutputs(sequence, result, slam, demoRunOutputs(), dir / toString(method));
    DemoRow row;
    row.method = method;
    row.tracking = OdometryMode::FrameToFrame;
    row.map_error_m = summary.map_error ? summary.map_error->point.mean : 0.0;
    row.map_error_p95_m = summary.map_error ? summary.map_error->point.p95 : 0.0;
    row.ate_m = summary.trajectory ? summary.trajectory->ape.translation.rmse : 0.0;
    row.frames_per_s = result.framesPerSecond();
    row.loops = result.loops.size();
    for (const auto& f : result.frames) row.fallbacks += (f.index > 0 && !f.icp_used);
    report.camera_rows.push_back(row);
    out << fmt::format("  {:<18} frame, camera labels: map error {:.3f} m, ATE {:.3f} m, {} loops\n", toString(method),
                       row.map_error_m, row.ate_m, row.loops);
  }
}

}  // namespace hazmap
