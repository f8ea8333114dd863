#include "hazmap/loop/landmarks.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <unordered_map>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {

struct CellKey {
  std::int32_t x, y, z;
  ClassId c;
  bool operator==(const CellKey& o) const { return x == o.x && y == o.y && z == o.z && c == o.c; }
};

struct CellHash {
  std::size_t operator()(const CellKey& k) const {
    std::uint64_t h = static_cast<std::uint32_t>(k.x) * 73856093ULL;
    h ^= static_cast<std::uint32_t>(k.y) * 19349663ULL;
    h ^= static_cast<std::uint32_t>(k.z) * 83492791ULL;
    h ^= static_cast<std::uint64_t>(k.c) << 48;
    return static_cast<std::size_t>(h);
  }
};

// Union-find with path halving; union by smaller root index keeps roots deterministic.
struct DisjointSets {
  std::vector<std::uint32_t> parent;
  explicit DisjointSets(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  }
  void unite(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    if (a < b) parent[b] = a; else parent[a] = b;
  }
};

PropertyLandmark describe(const LabeledCloud& cloud, const std::vector<std::size_t>& members) {
  PropertyLandmark lm;
  lm.class_id = cloud.classes[members.front()];
  lm.point_count = members.size();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  lm.box_min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  lm.box_max = -lm.box_min;
  for (std::size_t i : members) {
    const Eigen::Vector3d p = cloud.points[i].cast<double>();
    sum += p;
    lm.box_min = lm.box_min.cwiseMin(p);
    lm.box_max = lm.box_max.cwiseMax(p);
  }
  lm.centroid = sum / static_cast<double>(members.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t i : members) {
    const Eigen::Vector3d d = cloud.points[i].cast<double>() - lm.centroid;
    cov += d * d.transpose();
  }
  cov /= static_cast<double>(members.size());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  // Eigen sorts ascending; the descriptor lists the largest spread first.
  for (int k = 0; k < 3; ++k) {
    lm.extent(k) = std::sqrt(std::max(0.0, eig.eigenvalues()(2 - k)));
    lm.axes.col(k) = eig.eigenvectors().col(2 - k);
  }
  if (lm.axes.determinant() < 0) lm.axes.col(2) = -lm.axes.col(2);
  if (cloud.property.size() == cloud.size()) {
    double s = 0.0;
    for (std::size_t i : members) s += cloud.property[i];
    lm.has_property_value = true;
    lm.mean_property = s / static_cast<double>(members.size());
  }
  return lm;
}

}  // namespace

void validate(const LandmarkConfig& c) {
  const std::string where = "loop_closure.landmarks";
  if (!(c.cluster_tolerance > 0.0) || !std::isfinite(c.cluster_tolerance))
    fail(where, "cluster_tolerance must be a finite number > 0");
  if (c.min_points < 1) fail(where, "min_points must be >= 1");
  if (!(c.max_range >= 0.0) || !std::isfinite(c.max_range))
    fail(where, "max_range must be >= 0 (0 = no limit)");
}

std::vector<PropertyLandmark> extractLandmarks(const LabeledCloud& cloud, const ClassTable& table,
                                               const LandmarkConfig& config) {
  validate(config);
  if (cloud.classes.size() != cloud.size()) fail("extractLandmarks", "cloud has no per-point classes");
  const double tol = config.cluster_tolerance;
  const double tol2 = tol * tol;
  const double max_range2 = config.max_range > 0 ? config.max_range * config.max_range : 0.0;

  // Labelled points only (they are a few percent of a scan, so this stays small).
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!table.isProperty(cloud.classes[i])) continue;
    const Eigen::Vector3f& p = cloud.points[i];
    if (!p.allFinite()) continue;
    if (max_range2 > 0 && p.cast<double>().squaredNorm() > max_range2) continue;
    idx.push_back(i);
  }
  if (idx.empty()) return {};

  // Hash grid with cell = tolerance: every neighbour within `tol` lies in the 27 adjacent cells
  // of the same class.
  auto keyOf = [&](std::size_t i) {
    const Eigen::Vector3f& p = cloud.points[i];
    return CellKey{static_cast<std::int32_t>(std::floor(p.x() / tol)),
                   static_cast<std::int32_t>(std::floor(p.y() / tol)),
                   static_cast<std::int32_t>(std::floor(p.z() / tol)), cloud.classes[i]};
  };
  std::unordered_map<CellKey, std::vector<std::uint32_t>, CellHash> grid;
  grid.reserve(idx.size());
  for (std::uint32_t k = 0; k < idx.size(); ++k) grid[keyOf(idx[k])].push_back(k);

  DisjointSets sets(idx.size());
  for (std::uint32_t k = 0; k < idx.size(); ++k) {
    const CellKey key = keyOf(idx[k]);
    const Eigen::Vector3f& p = cloud.points[idx[k]];
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = grid.find(CellKey{key.x + dx, key.y + dy, key.z + dz, key.c});
          if (it == grid.end()) continue;
          for (std::uint32_t m : it->second) {
            if (m <= k) continue;
            if (sets.find(m) == sets.find(k)) continue;
            if ((cloud.points[idx[m]] - p).cast<double>().squaredNorm() <= tol2) sets.unite(k, m);
          }
        }
  }

  // Group by root; roots are the smallest member, so iterating k in order yields clusters
  // ordered by their lowest point index.
  std::unordered_map<std::uint32_t, std::size_t> slot;
  std::vector<std::vector<std::size_t>> clusters;
  for (std::uint32_t k = 0; k < idx.size(); ++k) {
    const std::uint32_t r = sets.find(k);
    auto [it, inserted] = slot.emplace(r, clusters.size());
    if (inserted) clusters.emplace_back();
    clusters[it->second].push_back(idx[k]);
  }
  std::vector<PropertyLandmark> out;
  for (const auto& members : clusters)
    if (members.size() >= config.min_points) out.push_back(describe(cloud, members));
  std::stable_sort(out.begin(), out.end(), [](const PropertyLandmark& a, const PropertyLandmark& b) {
    return a.class_id < b.class_id;
  });
  return out;
}

}  // namespace hazmap
