#pragma once
// `hazmap label`: a sequence + calibrated cameras → the same sequence with classes (and the
// first channel's values) from the cameras, and, when the input has ground-truth classes,
// per-class precision and recall of the camera labels.
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/io/sequence.hpp"
#include "hazmap/properties/labeler.hpp"
#include "hazmap/properties/view_fusion.hpp"

namespace hazmap {

struct LabelOptions {
  /// camera.yaml files (images next to them or `images:`) or rig files listing several
  std::vector<std::filesystem::path> cameras;
  /// With image_bag: one topic per entry of `cameras` (not for rig files), over the YAML's
  /// `topic:`; empty = each camera's own `topic:`.
  std::vector<std::string> image_topics;
  std::filesystem::path rules;                 ///< empty = built-in rules for the cameras' channels
  /// A bag whose image topics feed the cameras that name a `topic:` and no `images:` folder.
  std::filesystem::path image_bag;
  LabelerConfig labeler;
  /// Best-view fusion across scans (view_fusion.hpp), placed by the odometry (else the ground
  /// truth); off, or without poses, each scan keeps its own image's values.
  bool fuse_views = true;
  ViewFusionConfig fusion;
  bool overwrite = false;
  /// Oracle camera labels: every point the cameras observed (some channel has a value, view
  /// fusion included) keeps the input's own class (labels/, what a ground-truth run uses), every
  /// other point is `none` with no value, exactly as the camera labels leave it. Values and the
  /// class table are the camera run's. The bound of any labeler behind these cameras.
  bool oracle_labels = false;
  /// With oracle_labels: a class is kept only where a channel its rules read observed the point
  /// (heat where the thermal camera saw it, water where the NIR camera did) — what a labeler
  /// could know at all; without, where any camera did.
  bool oracle_per_channel = false;
};

/// Per property class, counted over all frames. "In view" = inside some camera's image.
struct ClassLabelMetrics {
  std::size_t true_points = 0;     ///< points of this class in the truth
  std::size_t observed = 0;        ///< of those, the ones a camera observed (a finite value)
  std::size_t true_positive = 0, false_positive = 0, false_negative = 0;  ///< in view
  std::optional<double> precision() const;
  std::optional<double> recall() const;
  std::optional<double> observedFraction() const;
};

struct LabelReport {
  std::size_t frames = 0, points = 0;
  std::vector<std::string> channels;
  /// Per channel, the cameras (camera_name of each calibration) that gave it, in order.
  std::map<std::string, std::vector<std::string>> channel_cameras;
  ProjectionStats projection;
  std::size_t in_view_points = 0;  ///< points inside at least one camera's image (stats count per camera)
  std::size_t images_missing = 0;  ///< (frame, camera) pairs without an image within the tolerance
  std::size_t valued = 0;          ///< points with a value after view fusion (= observed without it)
  bool fused = false;              ///< view fusion was applied
  std::string truth_source;        ///< labels_true/, labels/ or empty (no truth)
  std::map<std::string, ClassLabelMetrics> classes;  ///< property classes by name
  double seconds = 0.0;
};

/// The labeler for these camera files and rules over a sequence's class table.
/// Images come from the folder next to each camera.yaml (or its `images:`), or from `image_bag`'s
/// topic for a camera with `topic:` and no `images:`.
PropertyLabeler makeLabeler(const std::vector<std::filesystem::path>& cameras, const std::filesystem::path& rules,
                            const ClassTable& table, const LabelerConfig& config,
                            const std::filesystem::path& image_bag = {},
                            const std::vector<std::string>& image_topics = {});
/// The class table of camera-labelled scans: `input`'s, with no property class marking its
/// whole extent (a camera labels only what it saw of a region).
ClassTable cameraClassTable(const ClassTable& input);
/// The rules for cameras giving `channels`: the file's (checked against them), or with no file
/// the built-in rules for those channels. Throws when none applies.
PropertyRules cameraRules(const std::filesystem::path& rules, const std::vector<std::string>& channels,
                          const ClassTable& table);
/// Scan times of a sequence: times.txt (one per scan). Throws naming the file if missing/short.
std::vector<double> readScanTimes(const Sequence& sequence);
/// Labels every frame of `sequence_dir` and writes the labelled sequence to `out_dir`
/// atomically (velodyne/, labels/, the first channel as property, poses, odometry, times).
LabelReport labelSequence(const std::filesystem::path& sequence_dir, const std::filesystem::path& out_dir,
                          const LabelOptions& options);
/// Writes <labelled_dir>/overlays/<camera>_NNNNNN.png for one frame of a labelled sequence:
/// each camera's image nearest in time with the frame's points on it (overlay.hpp).
void writeLabelOverlays(const std::filesystem::path& labelled_dir, const std::vector<std::filesystem::path>& cameras,
                        std::size_t frame, const LabelerConfig& config);
/// {"frames", "points", "channels", "observed_fraction", "images_missing", "truth",
///  "labels": {class: {precision, recall, observed_fraction, true_points}}}
std::string labelReportJson(const LabelReport& report);

}  // namespace hazmap
