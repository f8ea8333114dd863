#pragma once
// Surface normals by PCA of the k nearest neighbours (within a radius). Needed by point-to-plane
// ICP on the target cloud. Normals point towards `viewpoint` (the sensor origin by default).
#include <Eigen/Core>
#include <span>
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

/// The PCA normal at `p` from its neighbours (p itself included, as a k-NN search returns it):
/// zero when fewer than 3 or when they do not span a plane (min_planarity); oriented towards
/// config.viewpoint. The building block of estimateNormals, for callers with their own search.
Eigen::Vector3f planeNormal(const Eigen::Vector3f& p, std::span<const Eigen::Vector3f> neighbors,
                            const NormalConfig& config);

/// `index` must index exactly `cloud.points` (ids = point indices). A point with fewer than 3
/// neighbours, or a non-finite one, gets the zero vector (= no normal). Parallel, deterministic.
std::vector<Eigen::Vector3f> estimateNormals(const LabeledCloud& cloud, const NeighborIndex& index,
                                             const NormalConfig& config = {});
/// Incremental form: recomputes `normals[i]` only where `stale[i]` is non-zero and keeps the
/// others (a local map whose neighbourhoods did not change). `normals` is resized to the cloud
/// (new entries zero); `stale` must be empty (= everything stale) or cloud-sized.
void updateNormals(const LabeledCloud& cloud, const NeighborIndex& index, const NormalConfig& config,
                   std::vector<Eigen::Vector3f>& normals, const std::vector<char>& stale);
/// Same, building a voxel-hash index itself. Throws hazmap::Error on bad config.
std::vector<Eigen::Vector3f> estimateNormals(const LabeledCloud& cloud, const NormalConfig& config = {});

/// The normal of `points[i]` alone (what updateNormals computes for it), for callers that need
/// only some normals and ask for them as they go. No config check (the callers did it).
Eigen::Vector3f normalAt(std::span<const Eigen::Vector3f> points, const NeighborIndex& index,
                         std::size_t i, const NormalConfig& config);

}  // namespace hazmap
