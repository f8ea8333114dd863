#include "hazmap/preprocess/spatial_index.hpp"

#include <nanoflann.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <string>

#include "hazmap/core/error.hpp"
#include "hazmap/core/hash.hpp"
#include "hazmap/core/voxel_key.hpp"
#include "hazmap/preprocess/top_k.hpp"

namespace hazmap {

namespace {

constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
inline std::uint64_t hashKey(std::uint64_t key) { return voxelProbeHash(key); }

inline bool finite(const Eigen::Vector3f& p) { return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z()); }

// Doubles an open-addressing table of slots {key, …} (kEmpty = unused) and re-inserts its keys.
template <class Slot>
void growTable(std::vector<Slot>& table, std::uint64_t& mask) {
  std::vector<Slot> old(2 * (mask + 1), Slot{kEmpty, 0, 0});
  old.swap(table);
  mask = table.size() - 1;
  for (const Slot& e : old) {
    if (e.key == kEmpty) continue;
    std::uint64_t slot = hashKey(e.key) & mask;
    while (table[slot].key != kEmpty) slot = (slot + 1) & mask;
    table[slot] = e;
  }
}

}  // namespace

VoxelHashIndex::VoxelHashIndex(std::span<const Eigen::Vector3f> points,
                               std::span<const std::uint32_t> ids, float cell_size,
                               float max_radius) {
  if (!(cell_size > 0.0f) || !std::isfinite(cell_size))
    fail("voxel hash index", "cell size must be > 0 (got " + std::to_string(cell_size) + ")");
  if (!(max_radius > 0.0f) || !std::isfinite(max_radius))
    fail("voxel hash index", "max radius must be > 0 (got " + std::to_string(max_radius) + ")");
  cell_ = cell_size;
  inv_cell_ = 1.0f / cell_size;
  const std::size_t n = ids.empty() ? points.size() : ids.size();
  // Sized for the voxels, not the points (several points share a voxel; a small table stays in
  // cache for the queries): start at n/4 and double whenever it is half full.
  table_mask_ = std::bit_ceil(std::max<std::uint64_t>(16, n / 4)) - 1;
  table_.assign(table_mask_ + 1, Slot{kEmpty, 0, 0});

  std::vector<std::uint32_t> cell_of(n, ~0u);
  std::vector<std::uint32_t> counts;
  counts.reserve(n / 2 + 1);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t id = ids.empty() ? static_cast<std::uint32_t>(i) : ids[i];
    const Eigen::Vector3f& p = points[id];
    if (!finite(p)) continue;
    std::uint64_t key;
    if (!voxelKey(static_cast<std::int64_t>(std::floor(p.x() * inv_cell_)),
                 static_cast<std::int64_t>(std::floor(p.y() * inv_cell_)),
                 static_cast<std::int64_t>(std::floor(p.z() * inv_cell_)), key))
      continue;  // farther than ~1e6 voxels from the origin: not indexable
    std::uint64_t slot = hashKey(key) & table_mask_;
    while (table_[slot].key != kEmpty && table_[slot].key != key) slot = (slot + 1) & table_mask_;
    if (table_[slot].key == kEmpty) {
      table_[slot].key = key;
      table_[slot].begin = static_cast<std::uint32_t>(counts.size());
      counts.push_back(0);
    }
    cell_of[i] = table_[slot].begin;
    ++counts[cell_of[i]];
    if (2 * counts.size() > table_mask_ + 1) growTable(table_, table_mask_);  // `slot` is stale after it
  }
  voxels_ = counts.size();
  std::vector<std::uint32_t> cell_begin(counts.size() + 1, 0);
  for (std::size_t c = 0; c < counts.size(); ++c) cell_begin[c + 1] = cell_begin[c] + counts[c];
  const std::size_t stored = cell_begin.back();
  points_.resize(stored);
  ids_.resize(stored);
  for (Slot& e : table_) {
    if (e.key == kEmpty) continue;
    const std::uint32_t c = e.begin;  // the voxel id until now
    e.begin = cell_begin[c];
    e.end = cell_begin[c + 1];
  }
  std::vector<std::uint32_t> fill(cell_begin.begin(), cell_begin.end() - 1);
  for (std::size_t i = 0; i < n; ++i) {
    if (cell_of[i] == ~0u) continue;
    const std::uint32_t id = ids.empty() ? static_cast<std::uint32_t>(i) : ids[i];
    const std::uint32_t at = fill[cell_of[i]]++;
    points_[at] = points[id];
    ids_[at] = id;
  }

  const int ring = static_cast<int>(std::ceil(max_radius / cell_size));
  ring_ = ring;
  const float max_lb2 = (max_radius / cell_size) * (max_radius / cell_size);
  for (int dx = -ring; dx <= ring; ++dx)
    for (int dy = -ring; dy <= ring; ++dy)
      for (int dz = -ring; dz <= ring; ++dz) {
        const auto gap = [](int d) { return static_cast<float>(std::max(std::abs(d) - 1, 0)); };
        const float lb2 = gap(dx) * gap(dx) + gap(dy) * gap(dy) + gap(dz) * gap(dz);
        if (lb2 <= max_lb2) offsets_.push_back({dx, dy, dz, lb2});
      }
  std::stable_sort(offsets_.begin(), offsets_.end(), [](const Offset& a, const Offset& b) {
    const int ma = std::abs(a.dx) + std::abs(a.dy) + std::abs(a.dz);
    const int mb = std::abs(b.dx) + std::abs(b.dy) + std::abs(b.dz);
    return a.lower_bound2 != b.lower_bound2 ? a.lower_bound2 < b.lower_bound2 : ma < mb;
  });
}

inline const VoxelHashIndex::Slot* VoxelHashIndex::findCell(std::int64_t x, std::int64_t y, std::int64_t z) const {
  std::uint64_t key;
  if (!voxelKey(x, y, z, key)) return nullptr;
  std::uint64_t slot = hashKey(key) & table_mask_;
  while (true) {
    const Slot& e = table_[slot];
    if (e.key == key) return &e;
    if (e.key == kEmpty) return nullptr;
    slot = (slot + 1) & table_mask_;
  }
}

std::int64_t VoxelHashIndex::nearest(const Eigen::Vector3f& q, float max_distance2,
                                     float& distance2) const {
  const float sx = q.x() * inv_cell_, sy = q.y() * inv_cell_, sz = q.z() * inv_cell_;
  const float bx = std::floor(sx), by = std::floor(sy), bz = std::floor(sz);
  const float fx = sx - bx, fy = sy - by, fz = sz - bz;  // position inside the voxel, [0, 1)
  const auto cx = static_cast<std::int64_t>(bx), cy = static_cast<std::int64_t>(by),
             cz = static_cast<std::int64_t>(bz);
  const float c2 = cell_ * cell_;
  float best = max_distance2;
  std::int64_t best_index = -1;
  const auto gap = [](int d, float f) {
    return d > 0 ? static_cast<float>(d) - f : (d < 0 ? f - static_cast<float>(d + 1) : 0.0f);
  };
  const auto scan = [&](std::int64_t x, std::int64_t y, std::int64_t z) {
    const Slot* cell = findCell(x, y, z);
    if (!cell) return;
    for (std::uint32_t i = cell->begin, end = cell->end; i < end; ++i) {
      const float d2 = (points_[i] - q).squaredNorm();
      if (d2 < best) {
        best = d2;
        best_index = i;
      }
    }
  };
  if (ring_ == 1) {
    // Radius within one voxel: the own voxel first, then only the neighbours on the sides the
    // query is close enough to (after the own voxel the bound is usually tight, so that is one
    // to three voxels instead of testing all 26).
    scan(cx, cy, cz);
    const float lim2 = best / c2;  // bound in voxel units²
    const int lo_x = fx * fx < lim2 ? -1 : 0, hi_x = (1.0f - fx) * (1.0f - fx) < lim2 ? 1 : 0;
    const int lo_y = fy * fy < lim2 ? -1 : 0, hi_y = (1.0f - fy) * (1.0f - fy) < lim2 ? 1 : 0;
    const int lo_z = fz * fz < lim2 ? -1 : 0, hi_z = (1.0f - fz) * (1.0f - fz) < lim2 ? 1 : 0;
    for (int dx = lo_x; dx <= hi_x; ++dx)
      for (int dy = lo_y; dy <= hi_y; ++dy)
        for (int dz = lo_z; dz <= hi_z; ++dz) {
          if (dx == 0 && dy == 0 && dz == 0) continue;
          const float gx = gap(dx, fx), gy = gap(dy, fy), gz = gap(dz, fz);
          if ((gx * gx + gy * gy + gz * gz) * c2 >= best) continue;
          scan(cx + dx, cy + dy, cz + dz);
        }
  } else {
    for (const Offset& o : offsets_) {
      if (o.lower_bound2 * c2 >= best) break;
      const float gx = gap(o.dx, fx), gy = gap(o.dy, fy), gz = gap(o.dz, fz);
      if ((gx * gx + gy * gy + gz * gz) * c2 >= best) continue;
      scan(cx + o.dx, cy + o.dy, cz + o.dz);
    }
  }
  if (best_index < 0) return -1;
  distance2 = best;
  return ids_[best_index];
}

void VoxelHashIndex::kNearest(const Eigen::Vector3f& q, int k, float max_distance2,
                              std::vector<Neighbor>& out) const {
  out.clear();
  if (k <= 0) return;
  const float sx = q.x() * inv_cell_, sy = q.y() * inv_cell_, sz = q.z() * inv_cell_;
  const float bx = std::floor(sx), by = std::floor(sy), bz = std::floor(sz);
  const float fx = sx - bx, fy = sy - by, fz = sz - bz;
  const auto cx = static_cast<std::int64_t>(bx), cy = static_cast<std::int64_t>(by),
             cz = static_cast<std::int64_t>(bz);
  const float c2 = cell_ * cell_;
  const auto gap = [](int d, float f) {
    return d > 0 ? static_cast<float>(d) - f : (d < 0 ? f - static_cast<float>(d + 1) : 0.0f);
  };
  TopK<Neighbor> best(out, static_cast<std::size_t>(k), max_distance2);
  for (const Offset& o : offsets_) {
    if (o.lower_bound2 * c2 >= best.bound()) break;
    const float gx = gap(o.dx, fx), gy = gap(o.dy, fy), gz = gap(o.dz, fz);
    if ((gx * gx + gy * gy + gz * gz) * c2 >= best.bound()) continue;
    const Slot* cell = findCell(cx + o.dx, cy + o.dy, cz + o.dz);
    if (!cell) continue;
    for (std::uint32_t i = cell->begin, end = cell->end; i < end; ++i) {
      const float d2 = (points_[i] - q).squaredNorm();
      if (d2 < best.bound()) best.push({ids_[i], d2});
    }
  }
  best.finish();
}

// ---------------------------------------------------------------------------------------------
struct KdTreeIndex::Impl {
  struct Adaptor {
    const std::vector<Eigen::Vector3f>* pts;
    std::size_t kdtree_get_point_count() const { return pts->size(); }
    float kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*pts)[i][dim]; }
    template <class B>
    bool kdtree_get_bbox(B&) const { return false; }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Adaptor>,
                                                   Adaptor, 3, std::uint32_t>;
  std::vector<Eigen::Vector3f> points;
  std::vector<std::uint32_t> ids;
  Adaptor adaptor{&points};
  std::unique_ptr<Tree> tree;
};

KdTreeIndex::KdTreeIndex(std::span<const Eigen::Vector3f> points, std::span<const std::uint32_t> ids)
    : impl_(std::make_unique<Impl>()) {
  const std::size_t n = ids.empty() ? points.size() : ids.size();
  impl_->points.reserve(n);
  impl_->ids.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t id = ids.empty() ? static_cast<std::uint32_t>(i) : ids[i];
    if (!finite(points[id])) continue;
    impl_->points.push_back(points[id]);
    impl_->ids.push_back(id);
  }
  impl_->adaptor.pts = &impl_->points;
  impl_->tree = std::make_unique<Impl::Tree>(3, impl_->adaptor,
                                             nanoflann::KDTreeSingleIndexAdaptorParams(10));
  impl_->tree->buildIndex();
}

KdTreeIndex::~KdTreeIndex() = default;

std::size_t KdTreeIndex::size() const { return impl_->points.size(); }

std::int64_t KdTreeIndex::nearest(const Eigen::Vector3f& q, float max_distance2, float& distance2) const {
  if (impl_->points.empty()) return -1;
  std::uint32_t idx = 0;
  float d2 = max_distance2;
  nanoflann::KNNResultSet<float, std::uint32_t> rs(1);
  rs.init(&idx, &d2);
  d2 = max_distance2;  // init() sets it to +inf; bound the search by the radius instead
  impl_->tree->findNeighbors(rs, q.data(), nanoflann::SearchParams(32, 0.0f, false));
  if (!(d2 < max_distance2) || rs.size() == 0) return -1;
  distance2 = d2;
  return impl_->ids[idx];
}

void KdTreeIndex::kNearest(const Eigen::Vector3f& q, int k, float max_distance2,
                           std::vector<Neighbor>& out) const {
  out.clear();
  if (k <= 0 || impl_->points.empty()) return;
  std::vector<std::uint32_t> idx(k);
  std::vector<float> d2(k);
  nanoflann::KNNResultSet<float, std::uint32_t> rs(k);
  rs.init(idx.data(), d2.data());
  const std::size_t found = impl_->tree->findNeighbors(rs, q.data(), nanoflann::SearchParams()) ? rs.size() : 0;
  for (std::size_t i = 0; i < found; ++i)
    if (d2[i] < max_distance2) out.push_back({impl_->ids[idx[i]], d2[i]});
}

}  // namespace hazmap
