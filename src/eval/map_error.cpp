#include "hazmap/eval/map_error.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <nanoflann.hpp>
#include <nlohmann/json.hpp>

#include "hazmap/core/error.hpp"
#include "hazmap/core/voxel_key.hpp"
#include "hazmap/core/se3.hpp"
#include "map/voxel_hash.hpp"

namespace hazmap {

namespace {

// Voxel centroids of an assembled map (sum + count per voxel, keyed by packed integer coords).
class CentroidGrid {
 public:
  explicit CentroidGrid(double voxel) : inv_(1.0 / voxel) {}
  void add(const Eigen::Vector3d& p) {
    const Eigen::Vector3d q = (p * inv_).array().floor();
    if ((q.array().abs() >= double(kVoxelKeyBias)).any()) return;  // beyond ±2^20 voxels: ignore
    // Keyed (z, y, x): the centroids are listed in key order, z-major.
    std::uint64_t key = 0;
    voxelKey(static_cast<std::int64_t>(q.z()), static_cast<std::int64_t>(q.y()), static_cast<std::int64_t>(q.x()), key);
    auto& cell = cells_[key];
    cell.sum += p;
    ++cell.count;
  }
  std::vector<Eigen::Vector3f> centroids() const {
    // Sorted by key so the result does not depend on hash-table order.
    std::vector<std::pair<std::uint64_t, std::size_t>> ordered;
    ordered.reserve(cells_.size());
    for (std::size_t i = 0; i < cells_.size(); ++i) ordered.emplace_back(cells_.keyAt(i), i);
    std::sort(ordered.begin(), ordered.end());
    std::vector<Eigen::Vector3f> out;
    out.reserve(ordered.size());
    for (const auto& [k, i] : ordered) {
      const Cell& c = cells_.valueAt(i);
      out.push_back((c.sum / double(c.count)).cast<float>());
    }
    return out;
  }
  std::size_t size() const { return cells_.size(); }

 private:
  struct Cell {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    std::uint32_t count = 0;
  };
  double inv_;
  detail::VoxelHashMap<Cell> cells_;
};

struct PointsAdaptor {
  const std::vector<Eigen::Vector3f>& pts;
  std::size_t kdtree_get_point_count() const { return pts.size(); }
  float kdtree_get_pt(std::size_t i, std::size_t d) const { return pts[i][static_cast<int>(d)]; }
  template <class B>
  bool kdtree_get_bbox(B&) const { return false; }
};
using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, PointsAdaptor>,
                                                   PointsAdaptor, 3, std::uint32_t>;

// Nearest-neighbour distance of (an even stride of at most max_queries of) `queries` to `ref`.
std::vector<double> nearestDistances(const std::vector<Eigen::Vector3f>& queries,
                                     const std::vector<Eigen::Vector3f>& ref, std::size_t max_queries) {
  if (queries.empty() || ref.empty()) return {};
  PointsAdaptor adaptor{ref};
  KdTree tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  const std::size_t stride =
      max_queries == 0 ? 1 : std::max<std::size_t>(1, (queries.size() + max_queries - 1) / max_queries);
  const std::size_t n = (queries.size() + stride - 1) / stride;
  std::vector<double> out(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const auto& range) {
    for (std::size_t k = range.begin(); k < range.end(); ++k) {
      std::uint32_t idx = 0;
      float d2 = 0;
      tree.knnSearch(queries[k * stride].data(), 1, &idx, &d2);
      out[k] = std::sqrt(static_cast<double>(d2));
    }
  });
  return out;
}

// Indices 0, s, 2s, … with at most `max` entries spread evenly over [0, n).
template <class F>
void forStride(std::size_t n, std::size_t max, F&& f) {
  if (n == 0) return;
  if (max == 0 || max >= n) {
    for (std::size_t i = 0; i < n; ++i) f(i);
    return;
  }
  // Evenly spread: index k·n/max (integer arithmetic keeps it deterministic).
  for (std::size_t k = 0; k < max; ++k) f(k * n / max);
}

double percentile(const std::vector<double>& sorted, double q) {
  const double pos = q * static_cast<double>(sorted.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, sorted.size() - 1);
  const double frac = pos - static_cast<double>(lo);
  return sorted[lo] + frac * (sorted[hi] - sorted[lo]);
}

}  // namespace

DistanceStats summarizeDistances(std::vector<double> d) {
  DistanceStats s;
  if (d.empty()) return s;
  s.count = d.size();
  std::sort(d.begin(), d.end());
  double sum = 0, sq = 0;
  for (double v : d) {
    sum += v;
    sq += v * v;
  }
  s.mean = sum / double(d.size());
  s.rmse = std::sqrt(sq / double(d.size()));
  s.median = percentile(d, 0.5);
  s.p95 = percentile(d, 0.95);
  s.max = d.back();
  return s;
}

struct MapErrorAccumulator::Impl {
  MapErrorConfig config;
  std::vector<float> distances;
  CentroidGrid est_map, true_map;
  std::size_t frames = 0;
  explicit Impl(const MapErrorConfig& c)
      : config(c), est_map(c.c2c_voxel_size), true_map(c.c2c_voxel_size) {}
};

MapErrorAccumulator::MapErrorAccumulator(MapErrorConfig config) {
  if (!(config.c2c_voxel_size > 0)) fail("map error", "c2c_voxel_size must be > 0");
  if (!(config.max_range >= 0)) fail("map error", "max_range must be >= 0");
  impl_ = std::make_unique<Impl>(config);
}
MapErrorAccumulator::~MapErrorAccumulator() = default;
MapErrorAccumulator::MapErrorAccumulator(MapErrorAccumulator&&) noexcept = default;
MapErrorAccumulator& MapErrorAccumulator::operator=(MapErrorAccumulator&&) noexcept = default;

std::size_t MapErrorAccumulator::frames() const { return impl_->frames; }

void MapErrorAccumulator::addFrame(const LabeledCloud& scan, const Eigen::Isometry3d& T_est,
                                   const Eigen::Isometry3d& T_true) {
  const std::string where = "map error: frame " + std::to_string(impl_->frames);
  if (!isFinite(T_est)) fail(where, "estimated pose is not finite");
  if (!isFinite(T_true)) fail(where, "true pose is not finite");
  const auto& cfg = impl_->config;
  const double max_r2 = cfg.max_range > 0 ? cfg.max_range * cfg.max_range : 0.0;
  const auto usable = [&](std::size_t i) {
    const Eigen::Vector3f& p = scan.points[i];
    if (!p.allFinite()) return false;
    return max_r2 == 0.0 || p.cast<double>().squaredNorm() <= max_r2;
  };
  forStride(scan.size(), cfg.max_points_per_frame, [&](std::size_t i) {
    if (!usable(i)) return;
    const Eigen::Vector3d p = scan.points[i].cast<double>();
    impl_->distances.push_back(static_cast<float>((T_est * p - T_true * p).norm()));
  });
  if (cfg.cloud_to_cloud) {
    forStride(scan.size(), cfg.c2c_points_per_frame, [&](std::size_t i) {
      if (!usable(i)) return;
      const Eigen::Vector3d p = scan.points[i].cast<double>();
      impl_->est_map.add(T_est * p);
      impl_->true_map.add(T_true * p);
    });
  }
  ++impl_->frames;
}

MapErrorResult MapErrorAccumulator::result() const {
  if (impl_->distances.empty()) fail("map error", "no scan points were added");
  MapErrorResult r;
  r.frames = impl_->frames;
  r.point = summarizeDistances(std::vector<double>(impl_->distances.begin(), impl_->distances.end()));
  if (impl_->config.cloud_to_cloud) {
    const auto est = impl_->est_map.centroids();
    const auto truth = impl_->true_map.centroids();
    r.est_map_voxels = est.size();
    r.true_map_voxels = truth.size();
    r.c2c = summarizeDistances(nearestDistances(est, truth, impl_->config.c2c_max_queries));
    r.c2c_reverse = summarizeDistances(nearestDistances(truth, est, impl_->config.c2c_max_queries));
  }
  return r;
}

MapErrorResult computeMapError(std::span<const LabeledCloud> scans, const Trajectory& est,
                               const Trajectory& truth, const MapErrorConfig& config) {
  if (scans.empty()) fail("map error", "no scans");
  if (est.size() != scans.size() || truth.size() != scans.size())
    fail("map error", std::to_string(scans.size()) + " scans but " + std::to_string(est.size()) +
                          " estimated and " + std::to_string(truth.size()) + " true poses");
  MapErrorAccumulator acc(config);
  for (std::size_t i = 0; i < scans.size(); ++i) acc.addFrame(scans[i], est.poses[i], truth.poses[i]);
  return acc.result();
}

std::string toJson(const MapErrorResult& r, int indent) {
  const auto stats = [](const DistanceStats& s) {
    return nlohmann::json{{"count", s.count}, {"mean", s.mean}, {"median", s.median},
                          {"p95", s.p95},     {"max", s.max},   {"rmse", s.rmse}};
  };
  nlohmann::json j;
  j["frames"] = r.frames;
  j["point"] = stats(r.point);
  j["c2c"] = stats(r.c2c);
  j["c2c_reverse"] = stats(r.c2c_reverse);
  j["est_map_voxels"] = r.est_map_voxels;
  j["true_map_voxels"] = r.true_map_voxels;
  return j.dump(indent);
}

}  // namespace hazmap
