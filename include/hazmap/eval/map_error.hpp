#pragma once
// Map error, the paper's Table 2 metric ("distance to the map built by the true trajectory"):
// every scan point is placed in the world twice — with the estimated pose and with the true pose
// of its frame — and the distance between the two placements is summarised (mean, median, 95th
// percentile). Because each point is compared with itself, the metric needs no correspondence
// search and measures exactly how far the estimated map is from the true one.
//
// Also reported: the cloud-to-cloud (C2C) distance, the nearest-neighbour distance from each
// point of the estimated map to the true map (and back), as a point-cloud tool such as
// CloudCompare would measure when correspondences are unknown.
//
// Points are subsampled deterministically (an even stride through each scan) so a 10,000-frame
// run stays cheap; the accumulator streams frame by frame and keeps only the distances and two
// voxel maps for the C2C part.
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/io/trajectory.hpp"

namespace hazmap {

struct MapErrorConfig {
  /// Points per frame used for the point-to-same-point error (even stride; 0 = all points).
  std::size_t max_points_per_frame = 1000;
  /// Compute the cloud-to-cloud nearest-neighbour distance as well.
  bool cloud_to_cloud = true;
  /// Points per frame fed into the two C2C maps (even stride; 0 = all points).
  std::size_t c2c_points_per_frame = 2000;
  /// Voxel size (m) of the two C2C maps: one centroid per occupied voxel. Must be > 0.
  double c2c_voxel_size = 0.05;
  /// Upper bound on C2C query points (even stride over the estimated map's voxels).
  std::size_t c2c_max_queries = 50000;
  /// Scan points farther than this from the sensor are ignored (m; 0 = keep all). Far points
  /// turn a small rotation error into a large distance; the paper's maps are indoor (< 100 m).
  double max_range = 0.0;
};

/// Summary of a distance sample. median and p95 use linear interpolation between order
/// statistics (numpy's default percentile).
struct DistanceStats {
  std::size_t count = 0;
  double mean = 0, median = 0, p95 = 0, max = 0, rmse = 0;
};
DistanceStats summarizeDistances(std::vector<double> distances);

struct MapErrorResult {
  std::size_t frames = 0;
  DistanceStats point;           ///< ‖T_est p − T_true p‖ over subsampled points: Table 2 is point.mean
  DistanceStats c2c;             ///< estimated map → true map nearest-neighbour distance
  DistanceStats c2c_reverse;     ///< true map → estimated map
  std::size_t est_map_voxels = 0, true_map_voxels = 0;
};

/// Streams frames in; result() may be called at any time.
class MapErrorAccumulator {
 public:
  explicit MapErrorAccumulator(MapErrorConfig config = {});
  ~MapErrorAccumulator();
  MapErrorAccumulator(MapErrorAccumulator&&) noexcept;
  MapErrorAccumulator& operator=(MapErrorAccumulator&&) noexcept;

  /// `scan` in the sensor frame; T_world_sensor poses. Non-finite points are skipped; a
  /// non-finite pose throws hazmap::Error naming the frame.
  void addFrame(const LabeledCloud& scan, const Eigen::Isometry3d& T_est,
                const Eigen::Isometry3d& T_true);
  /// Throws hazmap::Error when no point was added.
  MapErrorResult result() const;
  std::size_t frames() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// One call over whole runs: scans[i] is placed with est.poses[i] and truth.poses[i].
/// Throws hazmap::Error on empty input or a length mismatch (naming the counts).
MapErrorResult computeMapError(std::span<const LabeledCloud> scans, const Trajectory& est,
                               const Trajectory& truth, const MapErrorConfig& config = {});

/// JSON object text {"frames", "point": {count, mean, median, p95, max, rmse}, "c2c": {...},
/// "c2c_reverse": {...}}.
std::string toJson(const MapErrorResult& result, int indent = 2);

}  // namespace hazmap
