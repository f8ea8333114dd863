#include "hazmap/preprocess/normals.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <string>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {

void checkConfig(const NormalConfig& config) {
  if (config.neighbors < 3)
    fail("normals", "neighbors must be >= 3 (got " + std::to_string(config.neighbors) + ")");
  if (!(config.radius > 0.0) || !std::isfinite(config.radius))
    fail("normals", "radius must be > 0 (got " + std::to_string(config.radius) + ")");
}

}  // namespace

Eigen::Vector3f planeNormal(const Eigen::Vector3f& p, std::span<const Eigen::Vector3f> neighbors,
                            const NormalConfig& config) {
  if (neighbors.size() < 3) return Eigen::Vector3f::Zero();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& q : neighbors) mean += q.cast<double>();
  mean /= static_cast<double>(neighbors.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& q : neighbors) {
    const Eigen::Vector3d d = q.cast<double>() - mean;
    cov.noalias() += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(cov);
  Eigen::Vector3f normal = es.eigenvectors().col(0).cast<float>();
  // Collinear neighbours give no plane: a single scan ring on a wall or floor (VLP-16 rings
  // are 2° apart, so far surfaces are sampled by isolated lines) has a normal that PCA picks
  // at random around the line; such a "normal" biases pitch/roll. Require a spread in two
  // directions.
  const auto& ev = es.eigenvalues();
  if (!(ev(1) > 1e-12) || ev(1) < config.min_planarity * ev(2) || !normal.allFinite())
    return Eigen::Vector3f::Zero();
  if (normal.dot(config.viewpoint - p) < 0.0f) normal = -normal;
  return normal.normalized();
}

std::vector<Eigen::Vector3f> estimateNormals(const LabeledCloud& cloud, const NeighborIndex& index,
                                             const NormalConfig& config) {
  std::vector<Eigen::Vector3f> normals;
  updateNormals(cloud, index, config, normals, {});
  return normals;
}

void updateNormals(const LabeledCloud& cloud, const NeighborIndex& index, const NormalConfig& config,
                   std::vector<Eigen::Vector3f>& normals, const std::vector<char>& stale) {
  checkConfig(config);
  if (!stale.empty() && stale.size() != cloud.size())
    fail("normals", "stale mask has " + std::to_string(stale.size()) + " entries for " +
                        std::to_string(cloud.size()) + " points");
  normals.resize(cloud.size(), Eigen::Vector3f::Zero());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cloud.size(), 256), [&](const auto& range) {
    for (std::size_t i = range.begin(); i < range.end(); ++i)
      if (stale.empty() || stale[i]) normals[i] = normalAt(cloud.points, index, i, config);
  });
}

Eigen::Vector3f normalAt(std::span<const Eigen::Vector3f> points, const NeighborIndex& index,
                         std::size_t i, const NormalConfig& config) {
  const Eigen::Vector3f& p = points[i];
  if (!p.allFinite()) return Eigen::Vector3f::Zero();
  // Per-thread buffers: this runs once per point, often inside another parallel loop.
  thread_local std::vector<Neighbor> nb;
  thread_local std::vector<Eigen::Vector3f> pts;
  index.kNearest(p, config.neighbors, static_cast<float>(config.radius * config.radius), nb);
  pts.clear();
  for (const auto& n : nb) pts.push_back(points[n.index]);
  return planeNormal(p, pts, config);
}

std::vector<Eigen::Vector3f> estimateNormals(const LabeledCloud& cloud, const NormalConfig& config) {
  checkConfig(config);
  const VoxelHashIndex index(cloud.points, {}, static_cast<float>(config.radius) * 0.5f,
                             static_cast<float>(config.radius));
  return estimateNormals(cloud, index, config);
}

}  // namespace hazmap
