#include "hazmap/loop/landmarks.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <optional>
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

namespace {

using CellGrid = std::unordered_map<CellKey, std::vector<std::uint32_t>, CellHash>;

// The labelled points (a few percent of a scan, so what follows stays small): finite, of a
// property class, within max_range.
std::vector<std::size_t> labelledPoints(const LabeledCloud& cloud, const ClassTable& table, double max_range) {
  std::vector<char> is_property;  // class id → property? (a table lookup per point is slow)
  for (ClassId id : table.ids()) {
    if (id >= is_property.size()) is_property.resize(static_cast<std::size_t>(id) + 1, 0);
    is_property[id] = table.isProperty(id);
  }
  const double max_range2 = max_range > 0 ? max_range * max_range : 0.0;
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const ClassId c = cloud.classes[i];
    if (c >= is_property.size() || !is_property[c]) continue;
    const Eigen::Vector3f& p = cloud.points[i];
    if (!p.allFinite()) continue;
    if (max_range2 > 0 && p.cast<double>().squaredNorm() > max_range2) continue;
    idx.push_back(i);
  }
  return idx;
}

// The hash grid's cell of a point, per class (cell edge tol/√3, see extractLandmarks).
struct CellOf {
  const LabeledCloud& cloud;
  double cell;
  CellKey operator()(std::size_t i) const {
    const Eigen::Vector3f& p = cloud.points[i];
    return CellKey{static_cast<std::int32_t>(std::floor(p.x() / cell)),
                   static_cast<std::int32_t>(std::floor(p.y() / cell)),
                   static_cast<std::int32_t>(std::floor(p.z() / cell)), cloud.classes[i]};
  }
};

// Euclidean clustering of the labelled points idx[k] on the grid: all points of one cell are
// connected outright (the cell diagonal is tol), and every neighbour within tol lies within ±2
// cells. Cell pairs whose points are already connected are skipped, which keeps dense patches
// cheap.
DisjointSets connectWithin(const LabeledCloud& cloud, const std::vector<std::size_t>& idx, const CellGrid& grid,
                           const std::vector<CellKey>& order, double tol2) {
  DisjointSets sets(idx.size());
  for (const auto& [key, members] : grid)
    for (std::size_t m = 1; m < members.size(); ++m) sets.unite(members[0], members[m]);
  const auto joinCells = [&](const std::vector<std::uint32_t>& a, const std::vector<std::uint32_t>& b) {
    for (std::size_t s = 0; s < a.size(); ++s) {
      const Eigen::Vector3f& p = cloud.points[idx[a[s]]];
      for (std::size_t t = 0; t < b.size(); ++t)
        if ((cloud.points[idx[b[t]]] - p).cast<double>().squaredNorm() <= tol2) {
          sets.unite(a[s], b[t]);
          return;
        }
    }
  };
  for (const CellKey& key : order) {
    const auto& a = grid.find(key)->second;
    for (int dx = -2; dx <= 2; ++dx)
      for (int dy = -2; dy <= 2; ++dy)
        for (int dz = -2; dz <= 2; ++dz) {
          if (dx == 0 && dy == 0 && dz == 0) continue;
          auto it = grid.find(CellKey{key.x + dx, key.y + dy, key.z + dz, key.c});
          if (it == grid.end() || sets.find(a[0]) == sets.find(it->second[0])) continue;
          joinCells(a, it->second);
        }
  }
  return sets;
}

// The clusters as lists of cloud indices. Roots are the smallest member, so iterating k in
// order yields clusters ordered by their lowest point index.
std::vector<std::vector<std::size_t>> clustersOf(DisjointSets& sets, const std::vector<std::size_t>& idx) {
  std::unordered_map<std::uint32_t, std::size_t> slot;
  std::vector<std::vector<std::size_t>> clusters;
  for (std::uint32_t k = 0; k < idx.size(); ++k) {
    const std::uint32_t r = sets.find(k);
    auto [it, inserted] = slot.emplace(r, clusters.size());
    if (inserted) clusters.emplace_back();
    clusters[it->second].push_back(idx[k]);
  }
  return clusters;
}

// Purity: the share of the cluster among all points (any class) in the grid cells it occupies.
// A real source is mostly labelled where it is seen; label noise on a dense nearby wall chains
// into clusters whose cells hold hundreds of unlabelled points.
class Purity {
 public:
  Purity(const LabeledCloud& cloud, const CellOf& cell_of, const std::vector<std::vector<std::size_t>>& clusters,
         std::size_t min_points)
      : cell_of_(cell_of) {
    std::unordered_map<CellKey, char, CellHash> wanted;
    for (const auto& members : clusters)
      if (members.size() >= min_points)
        for (std::size_t i : members) wanted.emplace(anyClass(i), 1);
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (!cloud.points[i].allFinite()) continue;
      const CellKey k = anyClass(i);
      if (wanted.count(k)) ++all_counts_[k];
    }
  }
  double of(const std::vector<std::size_t>& members) {
    std::unordered_map<CellKey, char, CellHash> cells;
    for (std::size_t i : members) cells.emplace(anyClass(i), 1);
    std::size_t total = 0;
    for (const auto& kv : cells) total += all_counts_[kv.first];
    return total > 0 ? static_cast<double>(members.size()) / static_cast<double>(total) : 1.0;
  }

 private:
  CellKey anyClass(std::size_t i) const {
    CellKey k = cell_of_(i);
    k.c = 0;
    return k;
  }
  const CellOf& cell_of_;
  std::unordered_map<CellKey, std::uint32_t, CellHash> all_counts_;
};

}  // namespace

// Property landmarks (paper section V): the labelled points clustered per class, each cluster
// large and pure enough described by its centroid, extent and axes.
std::vector<PropertyLandmark> extractLandmarks(const LabeledCloud& cloud, const ClassTable& table,
                                               const LandmarkConfig& config) {
  validate(config);
  if (cloud.classes.size() != cloud.size()) fail("extractLandmarks", "cloud has no per-point classes");
  const std::vector<std::size_t> idx = labelledPoints(cloud, table, config.max_range);
  if (idx.empty()) return {};

  // Hash grid with cell edge tol/√3: the cell diagonal is tol.
  const double tol = config.cluster_tolerance;
  const CellOf cell_of{cloud, tol / std::sqrt(3.0)};
  CellGrid grid;
  std::vector<CellKey> order;  // cells in first-seen order (deterministic)
  grid.reserve(idx.size());
  for (std::uint32_t k = 0; k < idx.size(); ++k) {
    const CellKey key = cell_of(idx[k]);
    auto [it, inserted] = grid.try_emplace(key);
    if (inserted) order.push_back(key);
    it->second.push_back(k);
  }
  DisjointSets sets = connectWithin(cloud, idx, grid, order, tol * tol);
  const std::vector<std::vector<std::size_t>> clusters = clustersOf(sets, idx);

  std::optional<Purity> purity;
  if (config.min_purity > 0.0) purity.emplace(cloud, cell_of, clusters, config.min_points);
  std::vector<PropertyLandmark> out;
  for (const auto& members : clusters) {
    if (members.size() < config.min_points) continue;
    PropertyLandmark lm = describe(cloud, members);
    if (purity) {
      lm.purity = purity->of(members);
      if (lm.purity < config.min_purity) continue;
    }
    out.push_back(lm);
  }
  std::stable_sort(out.begin(), out.end(), [](const PropertyLandmark& a, const PropertyLandmark& b) {
    return a.class_id < b.class_id;
  });
  return out;
}

std::vector<PropertyLandmark> mergeLandmarks(
    const std::vector<std::vector<PropertyLandmark>>& per_keyframe, const PoseList& poses,
    std::size_t first, std::size_t last, std::size_t ref, double merge_distance) {
  if (first > last || last >= per_keyframe.size() || last >= poses.size() || ref >= poses.size())
    fail("mergeLandmarks", "keyframe range out of bounds");
  // Reference keyframe first, then by distance in index: nearer keyframes seed the merge.
  std::vector<std::size_t> order;
  for (std::size_t k = first; k <= last; ++k) order.push_back(k);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    auto d = [&](std::size_t k) { return k > ref ? k - ref : ref - k; };
    return d(a) < d(b);
  });
  const Eigen::Isometry3d T_ref_world = poses[ref].inverse();
  std::vector<PropertyLandmark> out;
  for (std::size_t k : order) {
    const Eigen::Isometry3d T = T_ref_world * poses[k];
    for (const PropertyLandmark& l : per_keyframe[k]) {
      PropertyLandmark t = l;
      t.centroid = T * l.centroid;
      t.axes = T.linear() * l.axes;
      // Bounds of the moved box: its eight corners.
      t.box_min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
      t.box_max = -t.box_min;
      for (int c = 0; c < 8; ++c) {
        const Eigen::Vector3d corner((c & 1) ? l.box_max.x() : l.box_min.x(),
                                     (c & 2) ? l.box_max.y() : l.box_min.y(),
                                     (c & 4) ? l.box_max.z() : l.box_min.z());
        const Eigen::Vector3d q = T * corner;
        t.box_min = t.box_min.cwiseMin(q);
        t.box_max = t.box_max.cwiseMax(q);
      }
      PropertyLandmark* into = nullptr;
      double best = merge_distance;
      for (auto& o : out) {
        const double d = (o.centroid - t.centroid).norm();
        if (o.class_id == t.class_id && d <= best) {
          best = d;
          into = &o;
        }
      }
      if (!into) {
        out.push_back(t);
        continue;
      }
      const double wa = static_cast<double>(into->point_count), wb = static_cast<double>(t.point_count);
      const double w = wa + wb > 0 ? wb / (wa + wb) : 0.5;
      into->centroid = (1 - w) * into->centroid + w * t.centroid;
      if (into->has_property_value && t.has_property_value)
        into->mean_property = (1 - w) * into->mean_property + w * t.mean_property;
      if (t.extent(0) > into->extent(0)) {
        into->extent = t.extent;
        into->axes = t.axes;
      }
      into->box_min = into->box_min.cwiseMin(t.box_min);
      into->box_max = into->box_max.cwiseMax(t.box_max);
      into->point_count += t.point_count;
    }
  }
  std::stable_sort(out.begin(), out.end(), [](const PropertyLandmark& a, const PropertyLandmark& b) {
    return a.class_id < b.class_id;
  });
  return out;
}

}  // namespace hazmap
