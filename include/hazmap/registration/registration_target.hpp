#pragma once
// A registration target prepared once and reused: per-class spatial indexes (the paper's wider
// same-class search costs little because property points live in their own small index), the
// all-points index, and — for point-to-plane — the target normals, each estimated the first time
// ICP pairs its point (a scan pair's ICP pairs ≈ 70 % of the target; the rest are never needed).
// Build it once for a local map or a loop-closure candidate and register many sources against it.
#include <Eigen/Core>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/preprocess/normals.hpp"
#include "hazmap/preprocess/spatial_index.hpp"
#include "hazmap/registration/registration.hpp"

namespace hazmap {

/// One candidate correspondence in the target.
struct TargetMatch {
  std::int64_t index = -1;  ///< target point index, -1 = none within the gates
  float distance2 = 0.0f;   ///< squared Euclidean distance (m²)
  float cost = 0.0f;        ///< distance2 + penalty (what the rule minimised)
  bool cross_class = false;  ///< classes differ (plain ICP reports it too, without penalty)
  /// One side of the pair was not observed (unobservedPoint()): paired without the mismatch
  /// penalty, whatever the classes say.
  bool unobserved = false;
};

/// A point no property sensor observed: its property value is NaN and its class is not a
/// property class (a camera left it `none` because it never saw it, not because it saw it cold;
/// a labelled point was observed whatever its value). Property ICP pairs such a point with any
/// class without the mismatch penalty α: "not observed" is no evidence of "observed and none".
/// Clouds without the property channel (label files, ground truth) have no unobserved points.
inline bool unobservedPoint(const LabeledCloud& cloud, std::size_t i, bool property_class) {
  return !property_class && cloud.hasProperty() && std::isnan(cloud.property[i]);
}

class RegistrationTarget {
 public:
  /// Copies the finite points of `cloud`. Throws hazmap::Error for an invalid config or a class
  /// missing from `classes` (only when config.use_classes).
  RegistrationTarget(const LabeledCloud& cloud, const ClassTable& classes,
                     const RegistrationConfig& config);
  /// For incremental users (the odometry's local map): takes the cloud by value (no copy when
  /// moved in) and, for point-to-plane, keeps `normals[i]` where `stale[i] == 0` — the caller
  /// vouches that those points' neighbourhoods (normal_radius) did not change since the normals
  /// were estimated with the same settings — and estimates the rest (on first use, like all
  /// normals here). `normals`/`stale` empty = estimate all (same result as the constructor
  /// above); otherwise both cloud-sized.
  RegistrationTarget(LabeledCloud&& cloud, const ClassTable& classes, const RegistrationConfig& config,
                     std::vector<Eigen::Vector3f> normals, const std::vector<char>& stale);
  /// Computes the normal of point i of the (finite) cloud on demand.
  using NormalSource = std::function<Eigen::Vector3f(std::size_t)>;
  /// Same, but the stale normals come from the caller: `lazy(i)` is called the first time ICP
  /// needs point i's normal (at most once per point, from any thread), and the target builds no
  /// all-points index for them (the local map has its own neighbour structure). The cloud
  /// must be all finite (indices are the cloud's), and `lazy` must stay valid while the target
  /// is used.
  RegistrationTarget(LabeledCloud&& cloud, const ClassTable& classes, const RegistrationConfig& config,
                     std::vector<Eigen::Vector3f> normals, const std::vector<char>& stale,
                     NormalSource lazy);
  ~RegistrationTarget();
  RegistrationTarget(RegistrationTarget&&) noexcept;
  RegistrationTarget& operator=(RegistrationTarget&&) noexcept;

  const LabeledCloud& cloud() const { return cloud_; }
  std::size_t size() const { return cloud_.size(); }
  bool empty() const { return cloud_.empty(); }
  /// Unit normals (zero = none) when built for point-to-plane, else empty. Estimates every
  /// pending lazy normal first.
  const std::vector<Eigen::Vector3f>& normals() const;
  bool hasNormals() const { return !normals_.empty(); }
  /// Normal of point j (estimated now if it is a pending lazy one). Thread-safe.
  const Eigen::Vector3f& normal(std::size_t j) const {
    if (!lazy_state_ || lazy_state_[j].load(std::memory_order_acquire) == kNormalReady) return normals_[j];
    return lazyNormal(j);
  }
  /// Normals storage without estimating pending ones: only for points whose normal() was called.
  const std::vector<Eigen::Vector3f>& normalsComputed() const { return normals_; }

  /// The paper's rule for one (already transformed) source point of class `cls` with property
  /// value `value` (ignored unless the property term is on). `cost_bound`: the caller knows a
  /// candidate of at most this cost (see costBound); the search skips everything costlier, which
  /// makes it cheap without changing its answer. `observed` false: the source point was not
  /// observed (unobservedPoint()), so it pairs with the nearest point of any class within the
  /// default radius, without penalty. An observed point pairs with an unobserved target point
  /// within the default radius without penalty too; only observed, differing classes pay α.
  TargetMatch match(const Eigen::Vector3f& p, ClassId cls, float value,
                    float cost_bound = std::numeric_limits<float>::infinity(), bool observed = true) const;

  /// The nearest target point of any class within the default radius, no penalty (labels
  /// ignored): what plain ICP would pair `p` with. `distance2_bound` as cost_bound above.
  /// TargetMatch::unobserved tells whether that target point was observed.
  TargetMatch nearestAnyClass(const Eigen::Vector3f& p, ClassId cls,
                              float distance2_bound = std::numeric_limits<float>::infinity()) const;

  /// An upper bound on the cost of `p`'s best match (match(), or nearestAnyClass() when
  /// `labels` is false), from a candidate the caller already has — ICP's previous partner
  /// `previous` (-1 = none). Infinity when that candidate is not within its gates any more (then
  /// it bounds nothing). Between ICP iterations a point moves little, so the bound is tight and
  /// the search touches one or two voxels instead of a neighbourhood.
  /// `observed` as in match().
  float costBound(const Eigen::Vector3f& p, ClassId cls, std::int64_t previous, bool labels,
                  bool observed = true) const;
  /// Share of class `cls` among the target's observed points (0 for an absent class).
  double classShare(ClassId cls) const;

  /// True if `config` asks for the same search structure this target was built with.
  bool compatibleWith(const RegistrationConfig& config, const ClassTable& classes) const;
  /// Search radius (m) for same-class partners of `cls` (the default radius for unknown classes).
  float sameClassRadius(ClassId cls) const;
  float defaultRadius() const { return radius_; }
  float penalty() const { return alpha_; }
  bool usesClasses() const { return use_classes_; }
  bool usesProperty() const { return property_weight_ > 0.0f; }

 private:
  void build(const ClassTable& classes, const RegistrationConfig& config, const std::vector<char>& stale);
  const Eigen::Vector3f& lazyNormal(std::size_t j) const;
  static constexpr std::uint8_t kNormalReady = 2;
  // Lazy normals: state per point (0 pending, 1 being estimated, 2 ready). Pending ones come
  // from lazy_ when the caller gave one, else from the all-points index with normal_config_.
  NormalSource lazy_;
  NormalConfig normal_config_;
  mutable std::unique_ptr<std::atomic<std::uint8_t>[]> lazy_state_;
  struct ClassSlot {
    ClassId cls = 0;
    float radius2 = 0.0f;
    std::unique_ptr<NeighborIndex> index;
  };
  LabeledCloud cloud_;
  mutable std::vector<Eigen::Vector3f> normals_;
  std::unique_ptr<NeighborIndex> all_;  ///< every point (plain ICP, normals)
  std::vector<ClassSlot> slots_;        ///< one per class present in the target (use_classes)
  /// Target points no sensor observed (unobservedPoint()), with classes: kept out of slots_ and
  /// indexed here; they pair with any class within the default radius, without penalty.
  /// unobserved_ is empty when the target has none (then every path is the labelled-only one).
  std::vector<char> unobserved_;
  std::unique_ptr<NeighborIndex> unobserved_index_;
  std::size_t observed_points_ = 0;
  bool unobservedTarget(std::int64_t j) const { return !unobserved_.empty() && unobserved_[j]; }
  TargetMatch matchAnyClass(const Eigen::Vector3f& p, ClassId cls, float value, float cost_bound) const;
  void markUnobserved(const ClassTable& classes, ClassId max_id);
  std::vector<std::int16_t> slot_of_class_;  ///< class id → slot, -1 = absent
  std::vector<float> class_radius_;     ///< class id → same-class radius (m)
  std::vector<std::size_t> class_count_;  ///< class id → points of that class
  bool use_classes_ = false;
  float radius_ = 1.0f;
  float alpha_ = 0.0f;
  float property_weight_ = 0.0f;
  // what the target was built with (for compatibleWith)
  IcpMetric metric_ = IcpMetric::PointToPlane;
  SpatialIndexKind index_kind_ = SpatialIndexKind::VoxelHash;
  float cell_ = 0.5f;
  LabelMode label_mode_ = LabelMode::Hard;
  float confidence_ = 1.0f;
};

}  // namespace hazmap
