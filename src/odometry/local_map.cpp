#include "hazmap/odometry/local_map.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <memory>
#include <string>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "hazmap/core/error.hpp"
#include "hazmap/core/voxel_key.hpp"
#include "hazmap/preprocess/normals.hpp"
#include "hazmap/preprocess/top_k.hpp"

namespace hazmap {

namespace {

// The voxel's index slot, or nullptr (no such voxel, or coordinates beyond the key's range).
template <class Index>
auto findVoxel(Index& index, std::int64_t x, std::int64_t y, std::int64_t z) {
  std::uint64_t key = 0;
  return voxelKey(x, y, z, key) ? index.find(key) : nullptr;
}

}  // namespace

LocalMap::LocalMap(const LocalMapConfig& config) : config_(config) {
  config_.validate();
  inverse_voxel_ = 1.0 / config_.voxel_size;
  min_point_distance2_ = static_cast<float>(config_.min_point_distance * config_.min_point_distance);
}

void LocalMap::clear() {
  voxels_.clear();
  integrations_ = 0;
  normal_neighbors_ = -1;
  index_.clear();
  points_ = 0;
}

LocalMap::Voxel LocalMap::newVoxel(const std::array<std::int64_t, 3>& c) {
  return Voxel{c[0], c[1], c[2], {}, {}, {}, 0, {}, {}, {}, {}, true, false, true, {}, {}};
}

// A point into voxel v: appended while the voxel has room, else a property point replaces the
// oldest unlabelled one (while property points hold at most half of it). `origin` = the
// integrate() call that brought it (reanchor() moves it with that call's correction). Touches v
// alone; 1 when the map gained a point.
std::size_t LocalMap::insertIntoVoxel(Voxel& v, const Eigen::Vector3f& p, ClassId cls, float value,
                                      std::uint32_t origin, const ClassTable& table) const {
  const float min_d2 = min_point_distance2_;
  const bool prop = table.isProperty(cls);
  if (min_d2 > 0.0f) {
    bool close = false;
    for (std::size_t k = 0; k < v.points.size() && !close; ++k)
      close = (v.points[k] - p).squaredNorm() < min_d2 && (!prop || v.classes[k] == cls);
    if (close) return 0;
  }
  if (static_cast<int>(v.points.size()) < config_.max_points_per_voxel) {
    v.points.push_back(p);
    v.classes.push_back(cls);
    v.values.push_back(value);
    v.origins.push_back(origin);
    v.property_points += prop;
    v.delta.push_back(p);
    v.changed = true;
    return 1;
  }
  if (!prop || 2 * v.property_points >= config_.max_points_per_voxel) return 0;
  // Replace the oldest unlabelled point.
  for (std::size_t k = 0; k < v.points.size(); ++k) {
    if (table.isProperty(v.classes[k])) continue;
    v.delta.push_back(v.points[k]);
    v.delta.push_back(p);
    v.points[k] = p;
    v.classes[k] = cls;
    v.values[k] = value;
    v.origins[k] = origin;
    if (k < v.normals.size()) v.normals[k].setZero();  // estimated anew
    if (k < v.updates.size()) v.updates[k] = 0;
    if (k < v.reach2.size()) v.reach2[k] = -1.0f;
    ++v.property_points;
    v.changed = true;
    break;
  }
  return 0;
}

// The scan's points into their voxels exactly as one point after the other would go: the voxels
// numbered in the order of their first point (serial: one hash probe per point), then each
// voxel's points in scan order with the voxels in parallel (a voxel's state depends on its own
// points only), then the new voxels linked to their neighbours in parallel. Point i came with
// integrate() call origins[i] (empty: the current one).
void LocalMap::addScan(const LabeledCloud& scan, bool values, std::span<const std::uint32_t> origins,
                       const ClassTable& table) {
  const std::size_t n = scan.size(), first_new = voxels_.size();
  constexpr std::uint32_t kNone = ~std::uint32_t{0};
  std::vector<std::uint32_t> voxel_of(n, kNone);
  const double inv = inverse_voxel_;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = scan.points[i];
    if (!p.allFinite()) continue;
    std::array<std::int64_t, 3> c;
    std::uint64_t key = 0;
    if (!voxelOfPoint(p.x() * inv, p.y() * inv, p.z() * inv, c, key)) continue;  // beyond ±2^20 voxels
    const auto [slot, inserted] = index_.tryEmplace(key, static_cast<std::uint32_t>(voxels_.size()));
    if (inserted) voxels_.push_back(newVoxel(c));
    voxel_of[i] = *slot;
  }
  // The touched voxels' points grouped by a counting sort (scan order kept inside a voxel).
  std::vector<std::uint32_t> touched, start(voxels_.size() + 1, 0);
  for (std::size_t i = 0; i < n; ++i)
    if (voxel_of[i] != kNone && start[voxel_of[i] + 1]++ == 0) touched.push_back(voxel_of[i]);
  for (std::size_t k = 0; k < voxels_.size(); ++k) start[k + 1] += start[k];
  std::vector<std::uint32_t> grouped(start.back());
  {
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < n; ++i)
      if (voxel_of[i] != kNone) grouped[fill[voxel_of[i]]++] = static_cast<std::uint32_t>(i);
  }
  const auto current = static_cast<std::uint32_t>(integrations_);
  std::atomic<std::size_t> added{0};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, touched.size(), 64), [&](const auto& range) {
    std::size_t here = 0;
    for (std::size_t t = range.begin(); t < range.end(); ++t) {
      const std::uint32_t k = touched[t];
      for (std::uint32_t g = start[k]; g < start[k + 1]; ++g) {
        const std::uint32_t i = grouped[g];
        here += insertIntoVoxel(voxels_[k], scan.points[i], scan.classes[i], values ? scan.property[i] : 0.0f,
                                origins.empty() ? current : origins[i], table);
      }
    }
    added += here;
  });
  points_ += added.load();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(first_new, voxels_.size(), 64), [&](const auto& range) {
    for (std::size_t k = range.begin(); k < range.end(); ++k) linkNeighbours(static_cast<std::uint32_t>(k), first_new);
  });
}

void LocalMap::integrate(const LabeledCloud& scan, const Eigen::Vector3d& origin, const ClassTable& table) {
  if (points_ == 0) has_values_ = scan.hasProperty();
  addScan(scan, has_values_ && scan.hasProperty(), {}, table);
  ++integrations_;
  // Bound the map: drop voxels far from the robot.
  const std::vector<std::array<std::int64_t, 3>> dropped = dropFarVoxels(origin);
  // Cached normals: a change anywhere within the normal radius makes a voxel's normals stale.
  for (Voxel& v : voxels_) {
    if (!v.changed) continue;
    v.changed = false;
    if (normal_ring_ == 1) {  // the ring is the neighbour table
      for (const std::int32_t at : v.neighbours)
        if (at >= 0) voxels_[at].normals_valid = false;
    } else {
      invalidateAround(v.x, v.y, v.z, false);
    }
  }
  for (const auto& d : dropped) invalidateAround(d[0], d[1], d[2], true);
}

// Every point moved by the correction of the integrate() call that brought it, then the voxels
// rebuilt in the old voxel order (so the result is deterministic) and bounded around `origin`.
// All normals are estimated anew: every voxel is new.
void LocalMap::reanchor(const std::vector<Eigen::Isometry3d>& corrections, const Eigen::Vector3d& origin,
                        const ClassTable& table) {
  if (corrections.size() < integrations_)
    fail("local map", "reanchor needs a correction for each of the " + std::to_string(integrations_) +
                          " integrated scans, got " + std::to_string(corrections.size()));
  std::vector<Voxel> old = std::move(voxels_);
  voxels_.clear();
  index_.clear();
  points_ = 0;
  std::vector<Eigen::Matrix4f> moves(corrections.size());
  for (std::size_t f = 0; f < corrections.size(); ++f) moves[f] = corrections[f].matrix().cast<float>();
  LabeledCloud moved;  // in the old voxel order, each point with its value and its scan
  moved.enableProperty();
  std::vector<std::uint32_t> origins;
  for (const Voxel& v : old)
    for (std::size_t i = 0; i < v.points.size(); ++i) {
      const Eigen::Matrix4f& m = moves[v.origins[i]];
      moved.push_back(m.topLeftCorner<3, 3>() * v.points[i] + m.topRightCorner<3, 1>(), v.classes[i], 0.0f, 0.0,
                      v.values[i]);
      origins.push_back(v.origins[i]);
    }
  old.clear();
  addScan(moved, true, origins, table);
  dropFarVoxels(origin);
  for (Voxel& v : voxels_) v.changed = false;
}

// Drops the voxels farther than max_distance from `origin` (swap-remove keeps it O(1) and
// deterministic); returns their coordinates.
std::vector<std::array<std::int64_t, 3>> LocalMap::dropFarVoxels(const Eigen::Vector3d& origin) {
  const double max_d2 = config_.max_distance * config_.max_distance;
  std::vector<std::array<std::int64_t, 3>> dropped;
  for (std::size_t k = 0; k < voxels_.size();) {
    const Voxel& v = voxels_[k];
    const Eigen::Vector3d centre((v.x + 0.5) * config_.voxel_size, (v.y + 0.5) * config_.voxel_size,
                                 (v.z + 0.5) * config_.voxel_size);
    if ((centre - origin).squaredNorm() <= max_d2) {
      ++k;
      continue;
    }
    dropped.push_back({v.x, v.y, v.z});
    points_ -= v.points.size();
    std::uint64_t key = 0;
    voxelKey(v.x, v.y, v.z, key);  // in range: the voxel was added with it
    index_.erase(key);
    unlinkNeighbours(static_cast<std::uint32_t>(k));
    if (k + 1 != voxels_.size()) {
      moveVoxel(static_cast<std::uint32_t>(voxels_.size() - 1), static_cast<std::uint32_t>(k));
      *findVoxel(index_, voxels_[k].x, voxels_[k].y, voxels_[k].z) = static_cast<std::uint32_t>(k);
    }
    voxels_.pop_back();
  }
  return dropped;
}

// A new voxel k and the voxels around it point at each other. Voxels from `first_new` on are
// new in the same batch and each writes its own entries; an older voxel's entry for k is written
// by k alone. So a batch links in parallel: no entry is written twice.
void LocalMap::linkNeighbours(std::uint32_t k, std::size_t first_new) {
  Voxel& v = voxels_[k];
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dz = -1; dz <= 1; ++dz) {
        const int slot = neighbourSlot(dx, dy, dz);
        const std::uint32_t* at = slot == 13 ? &k : findVoxel(std::as_const(index_), v.x + dx, v.y + dy, v.z + dz);
        v.neighbours[slot] = at ? static_cast<std::int32_t>(*at) : -1;
        if (at && slot != 13 && *at < first_new) voxels_[*at].neighbours[26 - slot] = static_cast<std::int32_t>(k);
      }
}

// Voxel k is going: the voxels around it forget it.
void LocalMap::unlinkNeighbours(std::uint32_t k) {
  const Voxel& v = voxels_[k];
  for (int slot = 0; slot < 27; ++slot)
    if (slot != 13 && v.neighbours[slot] >= 0) voxels_[v.neighbours[slot]].neighbours[26 - slot] = -1;
}

// Voxel `from` moves to position `to` (a swap-remove): the voxels around it follow.
void LocalMap::moveVoxel(std::uint32_t from, std::uint32_t to) {
  voxels_[to] = std::move(voxels_[from]);
  Voxel& v = voxels_[to];
  v.neighbours[13] = static_cast<std::int32_t>(to);
  for (int slot = 0; slot < 27; ++slot)
    if (slot != 13 && v.neighbours[slot] >= 0) voxels_[v.neighbours[slot]].neighbours[26 - slot] = static_cast<std::int32_t>(to);
}

void LocalMap::invalidateAround(std::int64_t x, std::int64_t y, std::int64_t z, bool force) {
  const int r = normal_ring_;
  for (std::int64_t dx = -r; dx <= r; ++dx)
    for (std::int64_t dy = -r; dy <= r; ++dy)
      for (std::int64_t dz = -r; dz <= r; ++dz) {
        const std::uint32_t* at = findVoxel(index_, x + dx, y + dy, z + dz);
        if (!at) continue;
        voxels_[*at].normals_valid = false;
        voxels_[*at].force = voxels_[*at].force || force;
      }
}

namespace {

// Calls f(k, voxel k, its first point's index in the target) for every voxel, in parallel.
template <class Voxels, class F>
void forEachVoxel(Voxels& voxels, const std::vector<std::size_t>& first, F&& f) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, voxels.size(), 64), [&](const auto& range) {
    for (std::size_t k = range.begin(); k < range.end(); ++k) f(k, voxels[k], first[k]);
  });
}

}  // namespace

// The registration target of the map: its points, and (point-to-plane) their normals — cached
// ones where the neighbourhood did not change, the rest estimated now or on first use.
RegistrationTarget LocalMap::makeTarget(const ClassTable& classes, const RegistrationConfig& config,
                                        bool lazy_normals) {
  // 1. the map's points in voxel order, written in parallel (each voxel at its prefix offset)
  std::vector<std::size_t> first(voxels_.size() + 1, 0);
  for (std::size_t k = 0; k < voxels_.size(); ++k) first[k + 1] = first[k] + voxels_[k].points.size();
  LabeledCloud out = gatherPoints(first);
  if (config.metric != IcpMetric::PointToPlane) return RegistrationTarget(std::move(out), classes, config, {}, {});

  // 2. which cached normals are stale (their neighbourhood changed or the settings did)
  useNormalSettings(config);
  auto near = std::make_shared<NearVoxels>();
  markStaleNormals(*near);
  // 3. the cached normals in target order, and which are pending
  std::vector<Eigen::Vector3f> normals(points_);
  std::vector<char> pending(points_);
  owner_.resize(points_);
  forEachVoxel(voxels_, first, [&](std::size_t k, Voxel& v, std::size_t at) {
    v.normals_valid = true;
    v.force = false;
    v.delta.clear();
    for (std::size_t i = 0; i < v.points.size(); ++i) {
      owner_[at + i] = {static_cast<std::uint32_t>(k), static_cast<std::uint32_t>(i)};
      pending[at + i] = v.reach2[i] < 0.0f;
      normals[at + i] = v.normals[i];
    }
  });
  // 4. the pending ones estimated now, or by the target when ICP first pairs a point with them
  //    (most never are). The map's own voxels are the neighbour search (estimateNormal).
  NormalConfig nc;
  nc.neighbors = config.normal_neighbors;
  nc.radius = config.normal_radius;
  if (!lazy_normals) {
    estimatePendingNormals(pending, nc, *near, normals);
    std::vector<char> none_stale(normals.size(), 0);
    return RegistrationTarget(std::move(out), classes, config, std::move(normals), none_stale);
  }
  auto lazy = [this, nc, near](std::size_t j) {
    const auto [k, i] = owner_[j];
    return estimateNormal(voxels_[k], i, nc, near->row(k));
  };
  return RegistrationTarget(std::move(out), classes, config, std::move(normals), pending, lazy);
}

LabeledCloud LocalMap::gatherPoints(const std::vector<std::size_t>& first) const {
  LabeledCloud out;
  if (has_values_) out.enableProperty();
  out.resize(points_);
  forEachVoxel(voxels_, first, [&](std::size_t, const Voxel& v, std::size_t at) {
    std::copy(v.points.begin(), v.points.end(), out.points.begin() + at);
    std::copy(v.classes.begin(), v.classes.end(), out.classes.begin() + at);
    if (has_values_) std::copy(v.values.begin(), v.values.end(), out.property.begin() + at);
  });
  return out;
}

// New normal settings make every cached normal stale; the ring of neighbour voxels follows the
// radius, visited nearest first (own voxel, faces, edges, corners, then the outer rings) as a
// k-NN search should.
void LocalMap::useNormalSettings(const RegistrationConfig& config) {
  if (config.normal_neighbors != normal_neighbors_ || config.normal_radius != normal_radius_) {
    for (Voxel& v : voxels_) {
      v.normals_valid = false;
      v.force = true;
    }
    normal_neighbors_ = config.normal_neighbors;
    normal_radius_ = config.normal_radius;
    normal_ring_ = std::max(1, static_cast<int>(std::ceil(config.normal_radius / config_.voxel_size)));
  }
  if (!normal_offsets_.empty() && normal_offsets_ring_ == normal_ring_) return;
  const int ring = normal_ring_;
  normal_offsets_.clear();
  for (int dx = -ring; dx <= ring; ++dx)
    for (int dy = -ring; dy <= ring; ++dy)
      for (int dz = -ring; dz <= ring; ++dz) normal_offsets_.push_back({dx, dy, dz});
  std::stable_sort(normal_offsets_.begin(), normal_offsets_.end(), [](const auto& a, const auto& b) {
    const auto m = [](const auto& o) {
      return std::max({std::abs(o[0]), std::abs(o[1]), std::abs(o[2])}) * 8 + std::abs(o[0]) + std::abs(o[1]) + std::abs(o[2]);
    };
    return m(a) < m(b);
  });
  normal_offsets_ring_ = normal_ring_;
}

// Marks pending (reach2 < 0) every point of a stale voxel whose neighbour set could have changed
// since its normal was estimated — exact: a change beyond its k-th neighbour cannot enter the
// set, a removed point beyond it was not in it. With a normal_updates budget, a point past it
// keeps its normal.
void LocalMap::markStaleNormals(NearVoxels& near) {
  std::vector<std::uint32_t> stale_voxels;
  near.row_of.assign(voxels_.size(), -1);
  const std::size_t ring = normal_offsets_.size();
  for (std::size_t k = 0; k < voxels_.size(); ++k) {
    Voxel& v = voxels_[k];
    v.normals.resize(v.points.size(), Eigen::Vector3f::Zero());
    v.updates.resize(v.points.size(), 0);
    v.reach2.resize(v.points.size(), -1.0f);
    if (v.normals_valid) continue;
    near.row_of[k] = static_cast<std::int32_t>(stale_voxels.size() * ring);
    stale_voxels.push_back(static_cast<std::uint32_t>(k));
  }
  near.voxels.assign(stale_voxels.size() * ring, -1);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, stale_voxels.size(), 8), [&](const auto& range) {
    std::vector<const Voxel*> around;
    for (std::size_t s_i = range.begin(); s_i < range.end(); ++s_i)
      markStaleInVoxel(voxels_[stale_voxels[s_i]], around, near.voxels.data() + s_i * ring);
  });
}

// `near` receives the voxels of v's ring (left -1 when v has nothing to re-estimate).
void LocalMap::markStaleInVoxel(Voxel& v, std::vector<const Voxel*>& around, std::int32_t* near) const {
  const int budget = config_.normal_updates;
  const auto allowed = [&](std::size_t i) { return budget == 0 || v.updates[i] < budget || v.normals[i].isZero(); };
  // With a normal_updates budget most voxels hold only spent points: skip the neighbour
  // lookups (27 hash probes) that would find nothing to do.
  bool any = false;
  for (std::size_t i = 0; i < v.points.size() && !any; ++i) any = allowed(i);
  if (!any) {
    near[0] = NearVoxels::kNotLookedUp;
    return;
  }
  around.clear();
  for (std::size_t k = 0; k < normal_offsets_.size(); ++k) {
    const auto& o = normal_offsets_[k];
    std::int32_t at = -1;
    if (normal_ring_ == 1) {
      at = v.neighbours[neighbourSlot(o[0], o[1], o[2])];
    } else if (const std::uint32_t* found = findVoxel(index_, v.x + o[0], v.y + o[1], v.z + o[2])) {
      at = static_cast<std::int32_t>(*found);
    }
    if (at < 0) continue;
    near[k] = at;
    if (!voxels_[at].delta.empty()) around.push_back(&voxels_[at]);
  }
  for (std::size_t i = 0; i < v.points.size(); ++i) {
    if (!allowed(i)) continue;
    bool moved = v.force || v.reach2[i] < 0.0f;
    for (std::size_t a = 0; a < around.size() && !moved; ++a)
      for (const Eigen::Vector3f& d : around[a]->delta)
        if ((d - v.points[i]).squaredNorm() <= v.reach2[i]) {
          moved = true;
          break;
        }
    if (moved) v.reach2[i] = -1.0f;  // pending: estimated on demand (reach2 < 0 = not estimated)
  }
}

void LocalMap::estimatePendingNormals(const std::vector<char>& pending, const NormalConfig& nc,
                                      const NearVoxels& near, std::vector<Eigen::Vector3f>& normals) {
  std::vector<std::size_t> todo;
  for (std::size_t j = 0; j < pending.size(); ++j)
    if (pending[j]) todo.push_back(j);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, todo.size(), 64), [&](const auto& range) {
    for (std::size_t t = range.begin(); t < range.end(); ++t) {
      const auto [k, i] = owner_[todo[t]];
      normals[todo[t]] = estimateNormal(voxels_[k], i, nc, near.row(k));
    }
  });
}

// The k nearest map points within normal_radius (the map's voxels visited nearest first, voxels
// beyond the current k-th distance skipped), their PCA normal, cached in the voxel with its reach.
// Called concurrently for different points: it writes only point i's entries. `near`: v's ring
// from markStaleNormals (nullptr = look each voxel up).
Eigen::Vector3f LocalMap::estimateNormal(Voxel& v, std::size_t i, const NormalConfig& nc,
                                         const std::int32_t* near) const {
  const float r2 = static_cast<float>(nc.radius * nc.radius);
  const std::size_t k_max = static_cast<std::size_t>(std::max(nc.neighbors, 1));
  const float vs = static_cast<float>(config_.voxel_size);
  struct Candidate {
    float distance2;
    Eigen::Vector3f point;
  };
  thread_local std::vector<Candidate> buffer;
  thread_local std::vector<Eigen::Vector3f> neighbours;
  const Eigen::Vector3f p = v.points[i];
  const Eigen::Vector3f lo(static_cast<float>(v.x) * vs, static_cast<float>(v.y) * vs,
                           static_cast<float>(v.z) * vs);
  const Eigen::Vector3f f = ((p - lo) / vs).cwiseMax(0.0f).cwiseMin(1.0f);  // position in the voxel
  TopK<Candidate> best(buffer, k_max, r2);
  for (std::size_t k = 0; k < normal_offsets_.size(); ++k) {
    const auto& o = normal_offsets_[k];
    // lower bound of the distance from p to the neighbour voxel's box
    float lb2 = 0.0f;
    for (int a = 0; a < 3; ++a) {
      const int d = o[a];
      const float g = d > 0 ? (static_cast<float>(d) - f[a]) : d < 0 ? (f[a] - static_cast<float>(d + 1)) : 0.0f;
      lb2 += g * g;
    }
    lb2 *= vs * vs;
    if (lb2 * 0.9999f >= best.bound()) continue;  // margin for the float box position
    std::int64_t at = -1;
    if (near) {
      at = near[k];
    } else if (const std::uint32_t* found = findVoxel(index_, v.x + o[0], v.y + o[1], v.z + o[2])) {
      at = *found;
    }
    if (at < 0) continue;
    for (const Eigen::Vector3f& q : voxels_[static_cast<std::size_t>(at)].points) {
      const float d2 = (q - p).squaredNorm();
      if (d2 < best.bound()) best.push({d2, q});
    }
  }
  best.finish();
  neighbours.clear();
  for (const Candidate& e : buffer) neighbours.push_back(e.point);
  v.normals[i] = planeNormal(p, neighbours, nc);
  v.reach2[i] = buffer.size() == k_max ? buffer.back().distance2 : r2;
  if (v.updates[i] < 255) ++v.updates[i];
  return v.normals[i];
}

LabeledCloud LocalMap::cloud() const {
  LabeledCloud out;
  if (has_values_) out.enableProperty();
  out.reserve(points_);
  for (const Voxel& v : voxels_)
    for (std::size_t k = 0; k < v.points.size(); ++k) out.push_back(v.points[k], v.classes[k], 0.0f, 0.0, v.values[k]);
  return out;
}

}  // namespace hazmap
