#pragma once
// `hazmap view`: one self-contained HTML file that shows a map in 3D in any current browser,
// offline (three.js from Debian's libjs-three and the map embedded; nothing is fetched). The
// map's points keep map.ply's colours, one layer per class; the trajectories, the hazards as
// labelled boxes with a table that flies the camera to them, point inspection, a distance tool,
// top-down and perspective views, a legend and a scale bar.
#include <Eigen/Core>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/map/export.hpp"
#include "hazmap/map/hazard_changes.hpp"
#include "hazmap/map/hazards.hpp"

namespace hazmap {

struct ViewerTrajectory {
  std::string name;  ///< "estimate", "ground truth", ...
  std::vector<Eigen::Vector3d> positions;
  Rgb color{208, 64, 255};
};

/// What the page shows.
struct ViewerScene {
  std::string title = "hazmap map";
  std::string source;  ///< where the map came from (shown under the title)
  LabeledCloud map;    ///< points, classes and (optional) property values
  ClassTable classes = ClassTable::defaults();
  MapColorConfig colors;  ///< the colours of map.ply
  std::vector<Hazard> hazards;
  /// What changed since the prior mission (changes.json of a run with --prior or a merge): a
  /// layer of markers (new, gone, moved with its arrow, …) and a table; none, no layer.
  std::vector<HazardChange> changes;
  std::vector<ViewerTrajectory> trajectories;
  /// Points above this z are hidden at first (an indoor map's ceiling); the page has a slider.
  std::optional<double> clip_above;
};

struct ViewerConfig {
  /// At most this many map points are embedded (an even, deterministic decimation); 0 = all.
  std::size_t max_points = 0;
  /// The whole file must stay under this size; a larger map is an error suggesting --max-points,
  /// unless `decimate_to_fit` is set (then the points are decimated until it fits).
  std::size_t max_bytes = std::size_t(30) << 20;
  bool decimate_to_fit = false;
  /// Points drawn at first (the page's detail slider starts at budget / points).
  std::size_t detail_budget = 3'000'000;
  /// Points drawn while the camera moves (keeps a 5-million-point map interactive).
  std::size_t moving_budget = 600'000;
  bool top_down_first = false;  ///< open in the top-down view instead of perspective
  /// The live view's page (`hazmap live`): the same page, which then connects to the server's
  /// WebSocket (/ws) and draws what it publishes; the offline page holds no network code.
  bool live = false;
  /// Where Debian's libjs-three puts three.min.js and examples/js/controls/OrbitControls.js.
  std::filesystem::path three_dir = "/usr/share/javascript/three";
};

struct ViewerReport {
  std::size_t points_total = 0;
  std::size_t points_embedded = 0;
  std::size_t bytes = 0;
};

/// The page's hazard list as JSON text (an array: id, class, kind, centroid, min, max, area_m2,
/// points, frame_count, mean_property, max_property, color), what its table and boxes show; the
/// live view publishes the same.
std::string viewerHazardsJson(const std::vector<Hazard>& hazards, const ClassTable& classes,
                              const MapColorConfig& colors = {});

/// The page as one string. Throws hazmap::Error when three.js is missing or the map does not
/// fit under max_bytes (the message suggests a --max-points that fits).
std::string viewerHtml(const ViewerScene& scene, const ViewerConfig& config = {},
                       ViewerReport* report = nullptr);
/// Writes the page atomically (never a half file).
ViewerReport writeViewer(const std::filesystem::path& path, const ViewerScene& scene,
                         const ViewerConfig& config = {});

/// The scene of a `hazmap run` (or `hazmap merge`) output folder: map.ply and hazards.json (required),
/// changes.json when there is one,
/// trajectory.kitti (estimate) and, when run.json names a sequence with poses.txt of the same
/// length, the ground truth. Throws hazmap::Error naming the missing or broken file.
ViewerScene loadRunScene(const std::filesystem::path& run_dir,
                         const ClassTable& classes = ClassTable::defaults());

}  // namespace hazmap
