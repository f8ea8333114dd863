#include "hazmap/registration/registration_target.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <thread>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "hazmap/core/error.hpp"
#include "hazmap/preprocess/normals.hpp"

namespace hazmap {

namespace {

std::unique_ptr<NeighborIndex> makeIndex(SpatialIndexKind kind, const std::vector<Eigen::Vector3f>& pts,
                                         const std::vector<std::uint32_t>& ids, float cell,
                                         float max_radius) {
  if (kind == SpatialIndexKind::KdTree) return std::make_unique<KdTreeIndex>(pts, ids);
  return std::make_unique<VoxelHashIndex>(pts, ids, cell, max_radius);
}

float cellSizeFor(const RegistrationConfig& c) {
  return static_cast<float>(c.index_cell_size > 0.0 ? c.index_cell_size : c.max_correspondence_distance);
}

void checkInputs(const LabeledCloud& cloud, const ClassTable& classes, const RegistrationConfig& config) {
  config.validate();
  cloud.checkConsistent("registration target");
  if (config.use_classes) classes.checkCloud(cloud, "registration target");
}

// The wider same-class search presumes the point's counterpart in the target carries the label
// too. Labels that do not mark their class's whole extent (a camera's patch ends where its view
// ended) break that: the nearest labelled point metres away is another part of the region, so
// such a class searches the default radius like any point (0 = default).
double sameClassSearchRadius(const ClassInfo& info) { return info.whole_extent ? info.search_radius : 0.0; }

std::vector<std::size_t> finiteIndices(const LabeledCloud& cloud) {
  std::vector<std::size_t> finite;
  finite.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (cloud.points[i].allFinite()) finite.push_back(i);
  return finite;
}

}  // namespace

RegistrationTarget::~RegistrationTarget() = default;
RegistrationTarget::RegistrationTarget(RegistrationTarget&&) noexcept = default;
RegistrationTarget& RegistrationTarget::operator=(RegistrationTarget&&) noexcept = default;

RegistrationTarget::RegistrationTarget(const LabeledCloud& cloud, const ClassTable& classes,
                                       const RegistrationConfig& config) {
  checkInputs(cloud, classes, config);
  const std::vector<std::size_t> finite = finiteIndices(cloud);
  cloud_ = finite.size() == cloud.size() ? cloud : cloud.select(finite);
  build(classes, config, {});
}

RegistrationTarget::RegistrationTarget(LabeledCloud&& cloud, const ClassTable& classes,
                                       const RegistrationConfig& config,
                                       std::vector<Eigen::Vector3f> normals,
                                       const std::vector<char>& stale) {
  checkInputs(cloud, classes, config);
  if (normals.size() != stale.size() || (!stale.empty() && stale.size() != cloud.size()))
    fail("registration target", "cached normals/stale mask do not match the cloud (" +
                                    std::to_string(normals.size()) + "/" + std::to_string(stale.size()) +
                                    " for " + std::to_string(cloud.size()) + " points)");
  const std::vector<std::size_t> finite = finiteIndices(cloud);
  if (finite.size() == cloud.size()) {
    cloud_ = std::move(cloud);
    normals_ = std::move(normals);
    build(classes, config, stale);
    return;
  }
  cloud_ = cloud.select(finite);
  std::vector<char> kept_stale;
  if (!stale.empty()) {
    normals_.resize(finite.size());
    kept_stale.resize(finite.size());
    for (std::size_t k = 0; k < finite.size(); ++k) {
      normals_[k] = normals[finite[k]];
      kept_stale[k] = stale[finite[k]];
    }
  }
  build(classes, config, kept_stale);
}

RegistrationTarget::RegistrationTarget(LabeledCloud&& cloud, const ClassTable& classes,
                                       const RegistrationConfig& config,
                                       std::vector<Eigen::Vector3f> normals,
                                       const std::vector<char>& stale, NormalSource lazy) {
  if (!lazy || config.metric != IcpMetric::PointToPlane) {  // nothing to estimate lazily
    *this = RegistrationTarget(std::move(cloud), classes, config, std::move(normals), stale);
    return;
  }
  checkInputs(cloud, classes, config);
  if (normals.size() != cloud.size() || stale.size() != cloud.size())
    fail("registration target", "lazy normals need cloud-sized normals and stale mask (" +
                                    std::to_string(normals.size()) + "/" + std::to_string(stale.size()) +
                                    " for " + std::to_string(cloud.size()) + " points)");
  if (!std::all_of(cloud.points.begin(), cloud.points.end(), [](const Eigen::Vector3f& p) { return p.allFinite(); }))
    fail("registration target", "lazy normals need a finite cloud");
  cloud_ = std::move(cloud);
  normals_ = std::move(normals);
  lazy_ = std::move(lazy);
  build(classes, config, stale);
}

const Eigen::Vector3f& RegistrationTarget::lazyNormal(std::size_t j) const {
  std::atomic<std::uint8_t>& state = lazy_state_[j];
  std::uint8_t expected = 0;
  if (state.compare_exchange_strong(expected, 1, std::memory_order_acquire)) {
    normals_[j] = lazy_ ? lazy_(j) : normalAt(cloud_.points, *all_, j, normal_config_);
    state.store(kNormalReady, std::memory_order_release);
  } else {
    while (state.load(std::memory_order_acquire) != kNormalReady) std::this_thread::yield();
  }
  return normals_[j];
}

const std::vector<Eigen::Vector3f>& RegistrationTarget::normals() const {
  if (lazy_state_) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cloud_.size(), 256), [&](const auto& range) {
      for (std::size_t j = range.begin(); j < range.end(); ++j) normal(j);
    });
  }
  return normals_;
}

void RegistrationTarget::build(const ClassTable& classes, const RegistrationConfig& config,
                               const std::vector<char>& stale) {
  use_classes_ = config.use_classes;
  radius_ = static_cast<float>(config.max_correspondence_distance);
  alpha_ = static_cast<float>(config.effectiveMismatchPenalty(classes));
  metric_ = config.metric;
  index_kind_ = config.index;
  cell_ = cellSizeFor(config);
  label_mode_ = config.label_mode;
  confidence_ = static_cast<float>(config.label_confidence);
  if (use_classes_ && label_mode_ == LabelMode::Soft) alpha_ *= confidence_ * confidence_;

  // The continuous-property term needs the channel; without it the term is off.
  property_weight_ = cloud_.hasProperty() ? static_cast<float>(config.property_weight) : 0.0f;

  ClassId max_id = 0;
  for (ClassId id : classes.ids()) max_id = std::max(max_id, id);
  markUnobserved(classes, max_id);
  for (std::size_t i = 0; i < cloud_.size(); ++i) {
    if (unobservedTarget(static_cast<std::int64_t>(i))) continue;
    const ClassId c = cloud_.classes[i];
    if (class_count_.size() <= c) class_count_.resize(std::size_t(c) + 1, 0);
    ++class_count_[c];
  }
  // Same-class radius per class id (0 in the table = the default radius).
  class_radius_.assign(std::size_t(max_id) + 1, radius_);
  for (ClassId id : classes.ids()) {
    const double r = sameClassSearchRadius(classes.at(id));
    if (r > 0.0) class_radius_[id] = static_cast<float>(r);
  }

  // The all-points index serves plain ICP's search and the normals; with classes and every
  // normal supplied by the caller (known, or from its lazy_ source) it is not needed.
  const bool all_known = !stale.empty() && std::none_of(stale.begin(), stale.end(), [](char c) { return c != 0; });
  const bool need_all = !use_classes_ || (metric_ == IcpMetric::PointToPlane && !all_known && !lazy_);
  if (need_all) {
    const float max_r = std::max(radius_, static_cast<float>(config.normal_radius));
    all_ = makeIndex(index_kind_, cloud_.points, {}, cell_, max_r);
  }
  if (use_classes_) {
    std::vector<std::vector<std::uint32_t>> members(std::size_t(max_id) + 1);
    std::vector<std::uint32_t> unobserved;
    for (std::size_t i = 0; i < cloud_.size(); ++i)
      (unobservedTarget(static_cast<std::int64_t>(i)) ? unobserved : members[cloud_.classes[i]]).push_back(std::uint32_t(i));
    if (!unobserved.empty()) unobserved_index_ = makeIndex(index_kind_, cloud_.points, unobserved, cell_, radius_);
    slot_of_class_.assign(std::size_t(max_id) + 1, -1);
    for (std::size_t c = 0; c < members.size(); ++c) {
      if (members[c].empty()) continue;
      const float r_same = class_radius_[c];
      const float r_max = std::max(r_same, radius_);
      ClassSlot slot;
      slot.cls = static_cast<ClassId>(c);
      slot.radius2 = r_same * r_same;
      slot.index = makeIndex(index_kind_, cloud_.points, members[c], std::max(cell_, r_max * 0.5f), r_max);  // wide property radii: coarser cells
      slot_of_class_[c] = static_cast<std::int16_t>(slots_.size());
      slots_.push_back(std::move(slot));
    }
  }
  if (metric_ == IcpMetric::PointToPlane) {
    normal_config_.neighbors = config.normal_neighbors;
    normal_config_.radius = config.normal_radius;
    // Stale normals are estimated on first use (lazyNormal), not here: ICP pairs only part of
    // the target (≈ 70 % of a scan pair's), and the estimates then run inside its parallel
    // search. Each normal is a function of the cloud alone, so the results do not change.
    if (stale.empty()) normals_.assign(cloud_.size(), Eigen::Vector3f::Zero());
    if (!all_known) {
      lazy_state_ = std::make_unique<std::atomic<std::uint8_t>[]>(cloud_.size());
      for (std::size_t i = 0; i < cloud_.size(); ++i) {
        const bool pending = stale.empty() || stale[i];
        lazy_state_[i].store(pending ? 0 : kNormalReady, std::memory_order_relaxed);
        if (pending) normals_[i].setZero();
      }
    }
  } else {
    normals_.clear();
  }
}

// Flags the points no sensor observed (unobservedPoint()); leaves unobserved_ empty when there
// are none, so fully labelled targets take exactly the paths they always took.
void RegistrationTarget::markUnobserved(const ClassTable& classes, ClassId max_id) {
  observed_points_ = cloud_.size();
  if (!cloud_.hasProperty()) return;
  std::vector<char> property_class(std::size_t(max_id) + 1, 0);
  for (ClassId id : classes.ids()) property_class[id] = classes.isProperty(id);
  std::vector<char> unobserved(cloud_.size(), 0);
  std::size_t count = 0;
  for (std::size_t i = 0; i < cloud_.size(); ++i) {
    const ClassId c = cloud_.classes[i];
    unobserved[i] = unobservedPoint(cloud_, i, c < property_class.size() && property_class[c]);
    count += unobserved[i];
  }
  if (count == 0) return;
  unobserved_ = std::move(unobserved);
  observed_points_ = cloud_.size() - count;
}

float RegistrationTarget::sameClassRadius(ClassId cls) const {
  return use_classes_ && cls < class_radius_.size() ? class_radius_[cls] : radius_;
}

bool RegistrationTarget::compatibleWith(const RegistrationConfig& config, const ClassTable& classes) const {
  if (config.use_classes != use_classes_ || config.index != index_kind_) return false;
  if (config.metric == IcpMetric::PointToPlane && metric_ != IcpMetric::PointToPlane) return false;
  if (static_cast<float>(config.max_correspondence_distance) != radius_) return false;
  if (cellSizeFor(config) != cell_) return false;
  const float pw = cloud_.hasProperty() ? static_cast<float>(config.property_weight) : 0.0f;
  if (pw != property_weight_) return false;
  if (use_classes_) {
    float a = static_cast<float>(config.effectiveMismatchPenalty(classes));
    if (config.label_mode == LabelMode::Soft)
      a *= static_cast<float>(config.label_confidence * config.label_confidence);
    if (a != alpha_ || config.label_mode != label_mode_) return false;
    for (ClassId id : classes.ids()) {
      const double r = sameClassSearchRadius(classes.at(id));
      const float expect = r > 0.0 ? static_cast<float>(r) : radius_;
      if (id >= class_radius_.size() || class_radius_[id] != expect) return false;
    }
  }
  return true;
}

float RegistrationTarget::costBound(const Eigen::Vector3f& p, ClassId cls, std::int64_t previous,
                                     bool labels, bool observed) const {
  constexpr float kNone = std::numeric_limits<float>::infinity();
  if (previous < 0 || previous >= static_cast<std::int64_t>(cloud_.size())) return kNone;
  const float d2 = (cloud_.points[previous] - p).squaredNorm();
  float cost = d2;
  if (labels && use_classes_) {
    // With the property term match() ranks each class's nearest point, not every point, by cost:
    // a costlier-looking partner can still be the answer, so no bound.
    if (property_weight_ > 0.0f) return kNone;
    // Valid only inside its gate: an own-class partner within the class radius, another class
    // within the default radius (match()'s gates).
    // A pair with an unobserved side: the default radius, no penalty (match()).
    const bool free = !observed || unobservedTarget(previous);
    const bool same = cloud_.classes[previous] == cls;
    const float gate = same && !free ? sameClassRadius(cls) : radius_;
    if (!(d2 < gate * gate)) return kNone;
    if (!same && !free) cost += alpha_;
  } else if (!(d2 < radius_ * radius_)) {  // plain ICP ranks by distance alone
    return kNone;
  }
  // Inclusive: the searches keep only strictly smaller distances, and the candidate itself must
  // stay findable.
  return cost * (1.0f + 1e-5f) + 1e-12f;
}

TargetMatch RegistrationTarget::match(const Eigen::Vector3f& p, ClassId cls, float value,
                                      float cost_bound, bool observed) const {
  TargetMatch m;
  const float r2 = radius_ * radius_;
  const auto propertyCost = [&](std::int64_t j) {
    const float dv = value - cloud_.property[j];
    return std::isnan(dv) ? 0.0f : property_weight_ * dv * dv;  // NaN value = source has none
  };
  if (!use_classes_) {
    float d2;
    const std::int64_t j = all_->nearest(p, std::min(r2, cost_bound), d2);
    if (j < 0) return m;
    // Reported (not penalised) so that plain ICP's class agreement can be compared.
    m = {j, d2, d2, cloud_.classes[j] != cls};
    if (property_weight_ > 0.0f) m.cost += propertyCost(j);
    return m;
  }
  if (!observed) return matchAnyClass(p, cls, value, cost_bound);
  // Same class first, within the class's (possibly wider) radius.
  const std::int16_t own = cls < slot_of_class_.size() ? slot_of_class_[cls] : std::int16_t(-1);
  float best = std::numeric_limits<float>::infinity();
  if (own >= 0) {
    float d2;
    const std::int64_t j = slots_[own].index->nearest(p, std::min(slots_[own].radius2, cost_bound), d2);
    if (j >= 0) {
      m = {j, d2, d2, false};
      best = d2 + (property_weight_ > 0.0f ? propertyCost(j) : 0.0f);
      m.cost = best;
    }
  }
  // An unobserved target point: the default radius, no penalty.
  if (unobserved_index_) {
    float d2;
    const std::int64_t j = unobserved_index_->nearest(p, std::min(r2, std::min(best, cost_bound)), d2);
    const float cost = j < 0 ? best : d2 + (property_weight_ > 0.0f ? propertyCost(j) : 0.0f);
    if (cost < best) {
      best = cost;
      m = {j, d2, cost, cloud_.classes[j] != cls, true};
    }
  }
  // Another class can only win if d² + α < best, i.e. within sqrt(best − α) (and the gate).
  if (std::min(best, cost_bound) > alpha_) {
    for (std::size_t s = 0; s < slots_.size(); ++s) {
      if (static_cast<std::int16_t>(s) == own) continue;
      const float limit = std::min(r2, std::min(best, cost_bound) - alpha_);
      if (!(limit > 0.0f)) break;
      float d2;
      const std::int64_t j = slots_[s].index->nearest(p, limit, d2);
      if (j < 0) continue;
      const float cost = d2 + alpha_ + (property_weight_ > 0.0f ? propertyCost(j) : 0.0f);
      if (cost < best) {
        best = cost;
        m = {j, d2, cost, true};
      }
    }
  }
  return m;
}

// An unobserved source point: the cheapest of each class's nearest point (and the nearest
// unobserved one) within the default radius, no penalty.
TargetMatch RegistrationTarget::matchAnyClass(const Eigen::Vector3f& p, ClassId cls, float value,
                                              float cost_bound) const {
  TargetMatch m;
  float best = std::numeric_limits<float>::infinity();
  const auto consider = [&](const NeighborIndex& index) {
    float d2;
    const std::int64_t j = index.nearest(p, std::min(radius_ * radius_, std::min(best, cost_bound)), d2);
    if (j < 0) return;
    float cost = d2;
    if (property_weight_ > 0.0f) {
      const float dv = value - cloud_.property[j];
      if (!std::isnan(dv)) cost += property_weight_ * dv * dv;
    }
    if (cost < best) {
      best = cost;
      m = {j, d2, cost, cloud_.classes[j] != cls, true};
    }
  };
  for (const ClassSlot& slot : slots_) consider(*slot.index);
  if (unobserved_index_) consider(*unobserved_index_);
  return m;
}

TargetMatch RegistrationTarget::nearestAnyClass(const Eigen::Vector3f& p, ClassId cls,
                                                float distance2_bound) const {
  TargetMatch m;
  float best = std::min(radius_ * radius_, distance2_bound);
  const auto consider = [&](const NeighborIndex& index) {
    float d2;
    const std::int64_t j = index.nearest(p, best, d2);
    if (j >= 0 && (m.index < 0 || d2 < best)) {
      best = d2;
      m = {j, d2, d2, cloud_.classes[j] != cls, unobservedTarget(j)};
    }
  };
  if (all_) {
    consider(*all_);
  } else {
    for (const ClassSlot& slot : slots_) consider(*slot.index);
    if (unobserved_index_) consider(*unobserved_index_);
  }
  return m;
}

double RegistrationTarget::classShare(ClassId cls) const {
  if (cloud_.empty() || cls >= class_count_.size()) return 0.0;
  return observed_points_ == 0 ? 0.0 : static_cast<double>(class_count_[cls]) / static_cast<double>(observed_points_);
}

}  // namespace hazmap
