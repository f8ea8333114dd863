#include "hazmap/pipeline/map_entropy.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <string>
#include <unordered_map>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "hazmap/core/error.hpp"
#include "hazmap/core/voxel_key.hpp"

namespace hazmap {

namespace {

// The placed points bucketed in cells of `radius` (a neighbourhood spans 3×3×3 cells).
struct Grid {
  double inv;
  std::unordered_map<std::uint64_t, std::vector<Eigen::Vector3d>> cells;
  bool cellOf(const Eigen::Vector3d& p, std::array<std::int64_t, 3>& c, std::uint64_t& key) const {
    return voxelOfPoint(p.x() * inv, p.y() * inv, p.z() * inv, c, key);
  }
};

// ½ ln det(2πe Σ) of the neighbours of q, or NaN with too few.
double entropyAt(const Grid& g, const Eigen::Vector3d& q, double r2, std::size_t min_neighbors) {
  std::array<std::int64_t, 3> c;
  std::uint64_t key = 0;
  if (!g.cellOf(q, c, key)) return std::numeric_limits<double>::quiet_NaN();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  std::size_t n = 0;
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dz = -1; dz <= 1; ++dz) {
        std::uint64_t k = 0;
        if (!voxelKey(c[0] + dx, c[1] + dy, c[2] + dz, k)) continue;
        const auto it = g.cells.find(k);
        if (it == g.cells.end()) continue;
        for (const auto& p : it->second) {
          const Eigen::Vector3d d = p - q;
          if (d.squaredNorm() > r2) continue;
          sum += d;
          outer += d * d.transpose();
          ++n;
        }
      }
  if (n < min_neighbors) return std::numeric_limits<double>::quiet_NaN();
  const Eigen::Vector3d mean = sum / static_cast<double>(n);
  Eigen::Matrix3d cov = outer / static_cast<double>(n) - mean * mean.transpose();
  cov.diagonal().array() += 1e-6;  // 1 mm²: a perfectly flat patch keeps a finite entropy
  return 0.5 * std::log(std::pow(2.0 * M_PI * M_E, 3) * cov.determinant());
}

}  // namespace

double meanMapEntropy(const std::vector<std::shared_ptr<const LabeledCloud>>& clouds,
                      const std::vector<Eigen::Isometry3d>& poses, const MapEntropyConfig& config) {
  if (clouds.size() != poses.size())
    fail("map entropy", std::to_string(clouds.size()) + " clouds but " + std::to_string(poses.size()) + " poses");
  if (!(config.radius > 0.0) || config.stride == 0) fail("map entropy", "radius and stride must be positive");
  Grid g{1.0 / config.radius, {}};
  std::vector<Eigen::Vector3d> queries;
  std::size_t counter = 0;
  for (std::size_t i = 0; i < clouds.size(); ++i) {
    if (!clouds[i]) continue;
    for (const auto& pf : clouds[i]->points) {
      const Eigen::Vector3d p = poses[i] * pf.cast<double>();
      std::array<std::int64_t, 3> c;
      std::uint64_t key = 0;
      if (!p.allFinite() || !g.cellOf(p, c, key)) continue;
      g.cells[key].push_back(p);
      if (counter++ % config.stride == 0) queries.push_back(p);
    }
  }
  // Per-query entropies in parallel, summed in order: the same value for any thread count.
  const double r2 = config.radius * config.radius;
  std::vector<double> h(queries.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queries.size(), 1024), [&](const auto& range) {
    for (std::size_t i = range.begin(); i < range.end(); ++i) h[i] = entropyAt(g, queries[i], r2, config.min_neighbors);
  });
  double sum = 0.0;
  std::size_t n = 0;
  for (double v : h)
    if (std::isfinite(v)) sum += v, ++n;
  return n ? sum / static_cast<double>(n) : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace hazmap
