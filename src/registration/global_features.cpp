// FPFH descriptors (Rusu, Blodow, Beetz, "Fast Point Feature Histograms for 3D registration",
// ICRA 2009), written from the paper's description: for a point pair with normals, a Darboux
// frame u = n_s, v = u × d̂, w = u × v gives three angles (α = v·n_t, φ = u·d̂, θ = atan2(w·n_t,
// u·n_t)); a point's simple histogram (SPFH) bins them over its neighbours; its FPFH adds the
// neighbours' SPFHs weighted by 1/distance. The descriptor does not depend on the pose.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <nanoflann.hpp>
#include <numbers>

#include "global_internal.hpp"
#include "hazmap/preprocess/normals.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"

namespace hazmap::global {
namespace {

// Internal thresholds of global registration (issue 37: named constants, not keys; their old
// keys name this file). docs/registration.md, "Global registration".
/// Neighbours per FPFH histogram, nearest first: enough for a stable histogram at 0.5 m voxels, bounded in time.
constexpr int kMaxFeatureNeighbors = 40;


int bin(float value, float lo, float hi) {
  const int b = static_cast<int>((value - lo) / (hi - lo) * kBins);
  return std::clamp(b, 0, kBins - 1);
}

// The three angles of a pair, binned into `hist` (the source of the frame is the point whose
// normal makes the smaller angle with the line joining them, so the result is symmetric).
void addPair(const Eigen::Vector3f& p1, const Eigen::Vector3f& n1, const Eigen::Vector3f& p2,
             const Eigen::Vector3f& n2, Descriptor& hist, float increment) {
  Eigen::Vector3f d = p2 - p1;
  const float len = d.norm();
  if (len <= 0.0f) return;
  d /= len;
  const bool swap = std::abs(n1.dot(d)) < std::abs(n2.dot(d));
  const Eigen::Vector3f& ns = swap ? n2 : n1;
  const Eigen::Vector3f& nt = swap ? n1 : n2;
  if (swap) d = -d;
  Eigen::Vector3f v = ns.cross(d);
  const float vn = v.norm();
  if (vn < 1e-6f) return;  // the line runs along the normal: the frame is undefined
  v /= vn;
  const Eigen::Vector3f w = ns.cross(v);
  const float alpha = v.dot(nt);
  const float phi = ns.dot(d);
  const float theta = std::atan2(w.dot(nt), ns.dot(nt));
  hist[bin(alpha, -1.0f, 1.0f)] += increment;
  hist[kBins + bin(phi, -1.0f, 1.0f)] += increment;
  hist[2 * kBins + bin(theta, -std::numbers::pi_v<float>, std::numbers::pi_v<float>)] += increment;
}

// Each 11-bin block sums to 100, so descriptors of dense and sparse neighbourhoods compare.
void normalizeBlocks(Descriptor& h) {
  for (int b = 0; b < 3; ++b) {
    float sum = 0.0f;
    for (int k = 0; k < kBins; ++k) sum += h[b * kBins + k];
    if (sum <= 0.0f) continue;
    for (int k = 0; k < kBins; ++k) h[b * kBins + k] *= 100.0f / sum;
  }
}

struct Neighborhoods {
  std::vector<std::vector<Neighbor>> of;  ///< per point, nearest first, itself excluded
};

// One k-NN search per point serves both the normal (its nearest normal_neighbors within
// normal_radius) and the histogram (all within feature_radius).
Neighborhoods findNeighbors(FeatureCloud& fc, const GlobalRegistrationConfig& config, const NormalConfig& nc) {
  Neighborhoods nb;
  const std::size_t n = fc.cloud.size();
  nb.of.resize(n);
  fc.normals.assign(n, Eigen::Vector3f::Zero());
  const int k = std::max(kMaxFeatureNeighbors, config.normal_neighbors) + 1;
  const float r2 = static_cast<float>(std::max(config.feature_radius * config.feature_radius,
                                               config.normal_radius * config.normal_radius));
  const float feature_r2 = static_cast<float>(config.feature_radius * config.feature_radius);
  const float normal_r2 = static_cast<float>(config.normal_radius * config.normal_radius);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 128), [&](const auto& range) {
    std::vector<Neighbor> found;
    std::vector<Eigen::Vector3f> local;
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      fc.index->kNearest(fc.cloud.points[i], k, r2, found);
      local.clear();
      for (const auto& q : found)
        if (q.distance2 < normal_r2 && static_cast<int>(local.size()) < config.normal_neighbors)
          local.push_back(fc.cloud.points[q.index]);
      fc.normals[i] = planeNormal(fc.cloud.points[i], local, nc);
      auto& mine = nb.of[i];
      for (const auto& q : found)
        if (q.index != i && q.distance2 < feature_r2 && static_cast<int>(mine.size()) < kMaxFeatureNeighbors)
          mine.push_back(q);
    }
  });
  return nb;
}

void computeDescriptors(FeatureCloud& fc, const GlobalRegistrationConfig& config, const NormalConfig& nc) {
  Neighborhoods nb = findNeighbors(fc, config, nc);
  // Points without a normal take no part in any histogram.
  for (auto& v : nb.of) std::erase_if(v, [&](const Neighbor& q) { return fc.normals[q.index].isZero(); });
  for (std::size_t i = 0; i < nb.of.size(); ++i)
    if (fc.normals[i].isZero()) nb.of[i].clear();
  const std::size_t n = fc.cloud.size();
  std::vector<Descriptor> spfh(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 256), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      spfh[i].fill(0.0f);
      for (const auto& q : nb.of[i])
        addPair(fc.cloud.points[i], fc.normals[i], fc.cloud.points[q.index], fc.normals[q.index], spfh[i], 1.0f);
      normalizeBlocks(spfh[i]);
    }
  });
  // Points with too few neighbours have no stable histogram: no descriptor.
  constexpr std::size_t kMinNeighbors = 5;
  for (std::size_t i = 0; i < n; ++i)
    if (nb.of[i].size() >= kMinNeighbors) fc.feature_point.push_back(static_cast<std::uint32_t>(i));
  fc.descriptors.resize(fc.feature_point.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, fc.feature_point.size(), 256), [&](const auto& range) {
    for (std::size_t f = range.begin(); f != range.end(); ++f) {
      const std::uint32_t i = fc.feature_point[f];
      Descriptor h = spfh[i];
      Descriptor others{};
      for (const auto& q : nb.of[i]) {
        const float w = 1.0f / std::max(std::sqrt(q.distance2), 1e-3f);
        for (int k = 0; k < kDescriptorSize; ++k) others[k] += w * spfh[q.index][k];
      }
      const float inv_k = 1.0f / static_cast<float>(nb.of[i].size());
      for (int k = 0; k < kDescriptorSize; ++k) h[k] += inv_k * others[k];
      normalizeBlocks(h);
      fc.descriptors[f] = h;
    }
  });
}

}  // namespace

FeatureCloud computeFeatures(const LabeledCloud& raw, const ClassTable& classes,
                             const GlobalRegistrationConfig& config, const Eigen::Vector3f& viewpoint) {
  FeatureCloud fc;
  const VoxelDownsampleConfig vd = propertyVoxels(config.voxel_size);
  if (config.max_range > 0.0) {
    RangeCropConfig crop;
    crop.max_range = config.max_range;
    fc.cloud = cropAndDownsample(raw, crop, vd, classes);
  } else {
    fc.cloud = voxelDownsample(raw, vd, classes);
  }
  fc.index = std::make_unique<KdTreeIndex>(fc.cloud.points, std::span<const std::uint32_t>{});
  NormalConfig nc;
  nc.neighbors = config.normal_neighbors;
  nc.radius = config.normal_radius;
  nc.viewpoint = viewpoint;
  // Lower than the ICP's: edges and corners get a normal too (FPFH needs every point it can get);
  // only a true line (a pole, a lone scan ring) has none.
  nc.min_planarity = 0.01;
  computeDescriptors(fc, config, nc);
  if (config.use_classes) fc.landmarks = clusterLandmarks(fc.cloud, classes, &fc.labelled);
  return fc;
}

// ---------------------------------------------------------------------------------------------
// Approximate descriptor search: the match returned is within (1 + eps) of the nearest. In 33
// dimensions an exact k-d tree search visits most leaves; an approximate one a few, and RANSAC
// does not need the exact nearest (measured on KITTI and naraha: docs/registration.md).
constexpr float kDescriptorSearchEps = 1.0f;

struct DescriptorIndex::Impl {
  struct Adaptor {
    const std::vector<Descriptor>* rows;
    std::size_t kdtree_get_point_count() const { return rows->size(); }
    float kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*rows)[i][dim]; }
    template <class B>
    bool kdtree_get_bbox(B&) const { return false; }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Adaptor>, Adaptor,
                                                   kDescriptorSize, std::uint32_t>;
  std::vector<Descriptor> rows;
  Adaptor adaptor{&rows};
  std::unique_ptr<Tree> tree;
};

DescriptorIndex::DescriptorIndex(const std::vector<Descriptor>& descriptors, std::vector<std::uint32_t> ids)
    : ids_(std::move(ids)), impl_(std::make_unique<Impl>()) {
  impl_->rows.reserve(ids_.size());
  for (std::uint32_t id : ids_) impl_->rows.push_back(descriptors[id]);
  impl_->adaptor.rows = &impl_->rows;
  impl_->tree = std::make_unique<Impl::Tree>(kDescriptorSize, impl_->adaptor,
                                             nanoflann::KDTreeSingleIndexAdaptorParams(10));
  if (!ids_.empty()) impl_->tree->buildIndex();
}

DescriptorIndex::~DescriptorIndex() = default;
DescriptorIndex::DescriptorIndex(DescriptorIndex&&) noexcept = default;
DescriptorIndex& DescriptorIndex::operator=(DescriptorIndex&&) noexcept = default;

std::int64_t DescriptorIndex::nearest(const Descriptor& query) const {
  if (ids_.empty()) return -1;
  std::uint32_t idx = 0;
  float d2 = 0.0f;
  nanoflann::KNNResultSet<float, std::uint32_t> rs(1);
  rs.init(&idx, &d2);
  impl_->tree->findNeighbors(rs, query.data(), nanoflann::SearchParams(32, kDescriptorSearchEps));
  return rs.size() ? static_cast<std::int64_t>(ids_[idx]) : -1;
}

DescriptorIndexes indexDescriptors(const FeatureCloud& fc, const ClassTable& classes, bool use_classes) {
  DescriptorIndexes out;
  std::vector<std::uint32_t> ids(fc.descriptors.size());
  for (std::uint32_t f = 0; f < ids.size(); ++f) ids[f] = f;
  out.all.emplace(fc.descriptors, std::move(ids));
  if (!use_classes) return out;
  std::map<ClassId, std::vector<std::uint32_t>> per_class;
  for (std::uint32_t f = 0; f < fc.feature_point.size(); ++f) {
    const ClassId c = fc.cloud.classes[fc.feature_point[f]];
    if (classes.isProperty(c)) per_class[c].push_back(f);
  }
  for (auto& [c, v] : per_class) out.by_class.emplace(c, DescriptorIndex(fc.descriptors, std::move(v)));
  return out;
}

std::int64_t nearestFor(const Descriptor& d, ClassId cls, const DescriptorIndexes& idx, const ClassTable& classes,
                        bool use_classes) {
  if (use_classes && classes.isProperty(cls)) {
    const auto it = idx.by_class.find(cls);
    return it == idx.by_class.end() ? -1 : it->second.nearest(d);
  }
  return idx.all->nearest(d);
}

}  // namespace hazmap::global
