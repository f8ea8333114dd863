// hazmap label SEQ --camera CAM.yaml [--camera ...] [--rules RULES.yaml] --out SEQ2: classes and
// property values from calibrated cameras (docs/properties.md).
#include <fmt/format.h>

#include <iostream>
#include <memory>

#include <unistd.h>

#include "command.hpp"
#include "hazmap/core/error.hpp"
#include "recording.hpp"
#include "hazmap/properties/label_sequence.hpp"

namespace hazmap::cli {
namespace {

struct LabelCliOptions {
  std::string sequence, out, rules;
  std::vector<std::string> cameras, image_topics;
  double time_tolerance = 0.1;
  ProjectionConfig projection;
  bool no_motion_compensation = false;
  bool no_view_fusion = false;
  ViewFusionConfig fusion;
  bool overwrite = false, json = false, oracle_labels = false, oracle_per_channel = false;
  long overlay = -1;
};

/// A recording (bag) is converted into a temporary folder next to --out first; its image topics
/// feed the cameras with `topic:`. The folder goes when the labelling is done.
struct ConvertedRecording {
  std::filesystem::path path;
  ~ConvertedRecording() {
    std::error_code ignored;
    if (!path.empty()) std::filesystem::remove_all(path, ignored);
  }
};

void label(const LabelCliOptions& o) {
  LabelOptions options;
  ConvertedRecording converted;
  std::string sequence = o.sequence;
  if (isRecording(o.sequence)) {
    if (o.overlay >= 0) fail("--overlay", "draws images from camera folders, not from a bag");
    const auto out = std::filesystem::absolute(o.out).lexically_normal();
    converted.path = out.parent_path() / ("." + out.filename().string() + ".recording-" + std::to_string(::getpid()));
    std::filesystem::remove_all(converted.path);
    convertRecording(o.sequence, converted.path, SourceFlags{}, true);
    sequence = converted.path.string();
    options.image_bag = o.sequence;
  }
  for (const auto& c : o.cameras) options.cameras.emplace_back(c);
  options.image_topics = o.image_topics;
  if (!o.image_topics.empty() && options.image_bag.empty()) fail("--image-topic", "needs a bag as input, not a folder");
  options.rules = o.rules;
  options.labeler.time_tolerance = o.time_tolerance;
  options.labeler.projection = o.projection;
  options.labeler.motion_compensation = !o.no_motion_compensation;
  options.fuse_views = !o.no_view_fusion;
  options.fusion = o.fusion;
  options.overwrite = o.overwrite;
  options.oracle_labels = o.oracle_labels;
  options.oracle_per_channel = o.oracle_per_channel;
  const LabelReport r = labelSequence(sequence, o.out, options);
  if (o.overlay >= 0)
    writeLabelOverlays(o.out, options.cameras, static_cast<std::size_t>(o.overlay), options.labeler);
  if (o.json) {
    std::cout << labelReportJson(r);
    return;
  }
  const auto pct = [](std::size_t a, std::size_t b) { return b ? 100.0 * double(a) / double(b) : 0.0; };
  std::cout << fmt::format("labelled {} frames ({} points) into {} in {:.1f} s: {:.1f} % in view, {:.1f} % observed, "
                           "{} occluded, {} missing images\n",
                           r.frames, r.points, o.out, r.seconds, pct(r.in_view_points, r.points),
                           pct(r.projection.observed, r.points), r.projection.occluded, r.images_missing);
  if (r.truth_source.empty()) return;
  std::cout << fmt::format("against {}/ (inside the cameras' view):\n", r.truth_source);
  const auto show = [](const std::optional<double>& v) { return v ? fmt::format("{:.3f}", *v) : std::string("-"); };
  for (const auto& [name, m] : r.classes)
    std::cout << fmt::format("  {:<12} precision {}  recall {}  observed {} of {} points\n", name, show(m.precision()),
                             show(m.recall()), show(m.observedFraction()), m.true_points);
}

const RegisterCommand registration{{
    "label",
    "Label a sequence from calibrated property cameras (thermal, NIR, gamma) and write it as a new sequence",
    [](CLI::App& app) {
      auto o = std::make_shared<LabelCliOptions>();
      app.add_option("sequence", o->sequence, "Sequence directory (velodyne/, times.txt, poses.txt or odometry.txt) or a bag with image topics")
          ->required();
      app.add_option("--camera", o->cameras, "camera.yaml (ROS camera_info + T_camera_lidar, time_offset, channel) or a rig YAML "
                     "(cameras: [files]); repeatable")
          ->required();
      app.add_option("--image-topic", o->image_topics,
                     "With a bag: the image topic of each --camera, in order (sensor_msgs/Image or CompressedImage); "
                     "default: the camera YAML's topic:");
      app.add_option("--rules", o->rules, "Class rules YAML (e.g. 'heat: temperature >= 60'); default: built-in rules");
      app.add_option("--out", o->out, "Output sequence folder")->required();
      app.add_option("--time-tolerance", o->time_tolerance, "Largest |image time - scan time| used (s)");
      app.add_option("--depth-cell", o->projection.depth_cell_px, "Depth-test z-buffer cell size (pixels)");
      app.add_option("--depth-splat", o->projection.splat_cells, "Depth-test splat radius (cells)");
      app.add_option("--edge-guard", o->projection.edge_guard_px,
                     "No hazard class where a pixel within N pixels would not give it (robust to calibration error)");
      app.add_option("--depth-tolerance", o->projection.depth_tolerance, "Depth-test tolerance (m)");
      app.add_flag("--no-motion-compensation", o->no_motion_compensation,
                   "Do not place images with the pose at their own time");
      app.add_flag("--no-view-fusion", o->no_view_fusion,
                   "Each scan from its own images only (default: each surface voxel from its best view in nearby scans)");
      app.add_option("--fusion-voxel", o->fusion.voxel, "View fusion: surface voxel (m)");
      app.add_option("--fusion-window", o->fusion.window, "View fusion: metres of travel a view may be used for");
      app.add_option("--calibration-uncertainty", o->fusion.calibration_uncertainty_deg,
                     "View fusion: the calibration's angular uncertainty (degrees)");
      app.add_option("--odometry-drift", o->fusion.odometry_drift, "View fusion: odometry drift (m per m travelled)");
      app.add_option("--overlay", o->overlay,
                     "Also draw frame N's points on each camera's image: OUT/overlays/<camera>_NNNNNN.png");
      app.add_flag("--oracle-labels", o->oracle_labels,
                   "Keep the input's own classes (labels/) on the points the cameras observed, 'none' elsewhere: "
                   "the best any labeler behind these cameras could do (docs/properties.md)");
      app.add_flag("--oracle-per-channel", o->oracle_per_channel,
                   "With --oracle-labels: keep a class only where a camera whose channel its rules read observed the point");
      app.add_flag("--overwrite", o->overwrite, "Replace --out if it is a previous sequence");
      app.add_flag("--json", o->json, "Print the report as JSON (labels.<class>.precision, .recall, .observed_fraction)");
      app.callback([o] { label(*o); });
    }}};

}  // namespace
}  // namespace hazmap::cli
