#pragma once
// Surface normals by PCA of the k nearest neighbours (within a radius). Needed by point-to-plane
// ICP on the target cloud. Normals point towards `viewpoint` (the sensor origin by default).
#include <Eigen/Core>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/preprocess/spatial_index.hpp"

namespace hazmap {

struct NormalConfig {
  int neighbors = 10;    ///< k nearest points (>= 3)
  double radius = 1.0;   ///< m, farther neighbours are ignored (> 0)
  Eigen::Vector3f viewpoint = Eigen::Vector3f::Zero();
  /// Middle / largest eigenvalue of the neighbourhood below this = a line, not a plane → no
  /// normal.
  double min_planarity = 0.05;
};

/// `index` must index exactly `cloud.points` (ids = point indices). A point with fewer than 3
/// neighbours, or a non-finite one, gets the zero vector (= no normal). Parallel, deterministic.
std::vector<Eigen::Vector3f> estimateNormals(const LabeledCloud& cloud, const NeighborIndex& index,
                                             const NormalConfig& config = {});
/// Same, building a voxel-hash index itself. Throws hazmap::Error on bad config.
std::vector<Eigen::Vector3f> estimateNormals(const LabeledCloud& cloud, const NormalConfig& config = {});

}  // namespace hazmap
