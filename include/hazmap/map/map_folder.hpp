#pragma once
// The reopenable map (issue 34, part 1): what `hazmap run` leaves in its output folder so a
// later mission can continue in the same frame. map.json is the manifest, written last and
// atomically: it names the format ("hazmap-map/1"), the class table, the keyframes (their
// frame, final pose, cloud file and property landmarks), the pose graph (graph.g2o, edges with
// their information = inverse covariance), the hazards (hazards.json, with the frames that saw
// them), the run's parameters (as run.json's) and every file's size and checksum. A folder without
// map.json, or whose files do not match it, is refused with one line naming what is wrong:
// never half-read.
//
//   map.json                 the manifest (below)
//   classes.yaml             the class table the keyframes' class ids refer to
//   keyframes/NNNNNN.pcd     keyframe clouds as tracking saw them (deskewed), sensor frame
//   graph.g2o, trajectory.kitti, hazards.json   (written by the run itself)
//   graph_extras.json        what graph.g2o cannot say: each edge's kind (loop edges carry a
//                            robust loss) and the gravity priors; optional (older folders)
//   search_overview.pcd      the keyframes at their poses, downsampled once: the input of the
//                            global registration that localises a later mission in this map
//                            (pipeline/prior_map.hpp); optional (older folders, merges)
#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/graph/pose_graph.hpp"
#include "hazmap/loop/landmarks.hpp"
#include "hazmap/map/hazards.hpp"

namespace hazmap {

/// The one format this build writes and reads.
inline constexpr const char* kMapFormat = "hazmap-map/1";

struct MapKeyframe {
  std::size_t frame = 0;  ///< index in the run that made the map
  double stamp = 0.0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  ///< final T_world_sensor
  std::string cloud;        ///< relative path of its cloud (binary PCD, class ids of `classes`)
  std::size_t points = 0;
  std::vector<PropertyLandmark> landmarks;  ///< in the keyframe's sensor frame
};

/// map.json "search_overview": what the overview cloud was made with, so a reader can tell
/// whether it is the one it would make itself (else it rebuilds it from the keyframes).
struct MapSearchOverview {
  std::string cloud;  ///< relative path (binary PCD, class ids of the map's classes)
  double voxel = 0.0;  ///< m, both downsamplings (each keyframe, then the union)
  /// The class ids that were property classes (the downsampling's vote prefers them).
  std::vector<ClassId> property_classes;
};

/// What map.json describes (without the clouds, which are read on demand).
struct MapManifest {
  std::string format = kMapFormat;
  std::string method;       ///< the SLAM method of the run
  std::string source;       ///< the input the run read
  std::size_t frames = 0;
  /// Height of the sensor above the floor (m), the median over the keyframes of
  /// sensorHeightAboveFloor; NaN when no keyframe showed a floor.
  double sensor_height = 0.0;
  std::vector<MapKeyframe> keyframes;
  /// The run's parameters (run.json "parameters") as JSON text.
  std::string parameters_json = "{}";
  std::optional<MapSearchOverview> search_overview;  ///< absent in older folders
};

/// One file of the folder as map.json lists it.
struct MapFileEntry {
  std::string path;  ///< relative to the folder
  std::uintmax_t bytes = 0;
  std::uint64_t fnv1a = 0;  ///< FNV-1a 64 of the bytes
};

/// FNV-1a 64 of a file's bytes (map.json's checksums). Throws hazmap::Error naming the file.
std::uint64_t fileChecksum(const std::filesystem::path& path);

/// Height of the sensor above the floor seen in `cloud` (sensor frame, z up): minus the 5th
/// percentile of z among the points within 6 m horizontally; NaN with fewer than 200 such points.
double sensorHeightAboveFloor(const LabeledCloud& cloud);

/// Removes map.json first (a folder being rewritten is not a map until the new manifest lands).
void invalidateMapFolder(const std::filesystem::path& dir);

/// Writes keyframe `frame`'s cloud as keyframes/NNNNNN.pcd (atomically) and returns its path
/// relative to `dir`.
std::string writeMapKeyframeCloud(const std::filesystem::path& dir, std::size_t frame, const LabeledCloud& cloud);

/// Writes graph_extras.json for `graph` (its loop and map-anchor edges by index, its gravity
/// priors and gravity_world), atomically; returns its path relative to `dir`.
std::string writeGraphExtras(const std::filesystem::path& dir, const PoseGraph& graph);

/// Copies another map's keyframe cloud file `from` as this folder's keyframes/NNNNNN.pcd (a
/// merge renumbers the frames) and returns its path relative to `dir`.
std::string copyMapKeyframeCloud(const std::filesystem::path& dir, std::size_t frame, const std::filesystem::path& from);

/// Writes classes.yaml and, last, map.json listing `files` (relative paths, which must exist:
/// the run's graph.g2o, trajectory.kitti, hazards.json), the keyframes' clouds and the search
/// overview's (when the manifest has one), each with its size and checksum. Atomic; throws hazmap::Error naming the file.
/// `graph_extras`: writeGraphExtras' path (named as map.json "graph_extras"; empty = none).
void writeMapManifest(const std::filesystem::path& dir, const MapManifest& manifest, const ClassTable& classes,
                      const std::vector<std::string>& files, const std::string& graph_extras = {});

/// An opened map: the manifest checked against the folder.
class MapFolder {
 public:
  const std::filesystem::path& dir() const { return dir_; }
  const MapManifest& manifest() const { return manifest_; }
  const std::vector<MapKeyframe>& keyframes() const { return manifest_.keyframes; }
  const ClassTable& classes() const { return classes_; }
  /// Keyframe k's cloud (sensor frame). Throws hazmap::Error naming the file.
  LabeledCloud loadKeyframe(std::size_t k) const;
  /// The search overview's cloud (map frame). Throws hazmap::Error when the map has none or the
  /// file cannot be read.
  LabeledCloud loadSearchOverview() const;
  /// graph.g2o, with its edges' kinds and gravity priors from graph_extras.json when the
  /// manifest names it (else every edge an odometry edge, no priors).
  PoseGraph graph() const;
  bool graphHasExtras() const { return !graph_extras_.empty(); }
  std::vector<Hazard> hazards() const;
  const std::vector<MapFileEntry>& files() const { return files_; }

 private:
  friend MapFolder openMap(const std::filesystem::path& dir);
  std::filesystem::path dir_;
  MapManifest manifest_;
  ClassTable classes_;
  std::vector<MapFileEntry> files_;
  std::string graph_extras_;  ///< relative path, empty when the manifest names none
};

/// Opens a map folder: map.json present and of format hazmap-map/1, every listed file present
/// with its size and checksum (the checksums computed side by side on the task arena's threads). Throws hazmap::Error with one line naming the folder and what is
/// missing or wrong (no map.json: an older run or one that did not finish; another format; a
/// missing, truncated or changed file; a broken manifest).
MapFolder openMap(const std::filesystem::path& dir);

}  // namespace hazmap
