#pragma once
// Mean map entropy (MME; Razlaw et al., "Evaluation of registration methods for sparse 3D laser
// scans", ECMR 2015): the mean over map points of ½·ln det(2πe·Σ), Σ the covariance of the points
// within `radius`. A map whose scans are placed consistently is crisp — its surfaces thin — and
// has the lower entropy; it needs no ground truth. Issue 14 uses it as the final accept test of
// the pose graph: the optimised trajectory is kept only when its map is at least as crisp as
// tracking's.
#include <Eigen/Geometry>
#include <functional>
#include <memory>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap {

struct MapEntropyConfig {
  double radius = 0.3;       ///< m, neighbourhood of a point
  std::size_t stride = 4;    ///< every stride-th point is a query (all points are neighbours)
  std::size_t min_neighbors = 5;
};

/// MME of the scans `clouds[i]` (sensor frame) placed with `poses[i]`. Throws on a size
/// mismatch or a non-positive radius; NaN when no query point has enough neighbours.
double meanMapEntropy(const std::vector<std::shared_ptr<const LabeledCloud>>& clouds,
                      const std::vector<Eigen::Isometry3d>& poses, const MapEntropyConfig& config = {});

}  // namespace hazmap
