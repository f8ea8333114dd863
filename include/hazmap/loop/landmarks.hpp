#pragma once
// Property landmarks (paper section V: "we utilize physical properties as landmark
// information"): the labelled points of one keyframe, clustered by class, each cluster summarised
// by a small descriptor that can be matched against other keyframes without any pose estimate.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap {

using PoseList = std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>;

struct LandmarkConfig {
  /// Euclidean clustering distance (m): two same-class points closer than this belong to the
  /// same landmark. Large enough to bridge the gaps between VLP-16 rings on a floor puddle a few
  /// metres away (ring spacing ≈ 0.3–0.6 m at 2–4 m range), small enough to keep separate
  /// sources apart (the simulator places them metres apart). Must be > 0.
  double cluster_tolerance = 0.7;
  /// Clusters with fewer points are label noise (the simulator flips 0.5 % of "none" points to a
  /// property class; those are isolated) and are dropped. Must be >= 1.
  std::size_t min_points = 8;
  /// Points farther than this from the sensor origin are ignored (0 = no limit). Beyond ~18 m
  /// the VLP-16's 2° ring spacing exceeds the cluster tolerance, so a far source breaks into
  /// one cluster per ring, each with a centroid biased by which rings hit it.
  double max_range = 15.0;
  /// A cluster must make up at least this share of all points (any class) in the grid cells
  /// it occupies (0 = off). Label noise (0.5 % of points, issue 3) on a wall 2 m away, where a
  /// VLP-16 puts thousands of points per m², chains into "clusters" of 10–30 points among
  /// thousands of unlabelled ones (purity ~1 %); a real source is mostly labelled (> 30 %).
  double min_purity = 0.2;
};

/// One cluster of same-class property points, in the frame of the cloud it came from.
struct PropertyLandmark {
  ClassId class_id = 0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  /// Principal standard deviations (m), largest first (PCA of the cluster's points): a
  /// rotation-invariant size/shape descriptor.
  Eigen::Vector3d extent = Eigen::Vector3d::Zero();
  /// Principal directions, column k belongs to extent(k) (right-handed).
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  Eigen::Vector3d box_min = Eigen::Vector3d::Zero();  ///< axis-aligned bounds
  Eigen::Vector3d box_max = Eigen::Vector3d::Zero();
  std::size_t point_count = 0;
  /// Share of the cluster among all points in its grid cells (1 when min_purity is off).
  double purity = 1.0;
  bool has_property_value = false;  ///< the cloud had a `property` channel
  double mean_property = 0.0;       ///< mean of that channel over the cluster (e.g. °C)
};

/// Clusters the property-class points of `cloud` (classes with kind != None in `table`) and
/// describes every cluster with >= min_points points. Deterministic: sorted by class, then by
/// the lowest point index in the cluster. Throws hazmap::Error on an invalid config.
std::vector<PropertyLandmark> extractLandmarks(const LabeledCloud& cloud, const ClassTable& table,
                                               const LandmarkConfig& config = {});

/// The landmarks of keyframes [first, last] expressed in the frame of keyframe `ref`, using
/// `poses` (world ← keyframe; locally accurate odometry is enough over a short window).
/// Same-class landmarks closer than `merge_distance` are fused: centroid, property value and
/// bounds weighted by point count / united, extent and axes of the larger one, counts summed.
/// A "place" seen over a few keyframes has more landmarks than one scan, which makes
/// constellations more distinctive. Throws hazmap::Error on indices out of range.
std::vector<PropertyLandmark> mergeLandmarks(
    const std::vector<std::vector<PropertyLandmark>>& per_keyframe, const PoseList& poses,
    std::size_t first, std::size_t last, std::size_t ref, double merge_distance);

/// Throws hazmap::Error("loop_closure.landmarks: ...") naming the bad parameter.
void validate(const LandmarkConfig& config);

}  // namespace hazmap
