// The ICP loop, in the order one run goes through it:
//   source selection      finite source points, evenly strided down to max_source_points
//   coarse stage          the far-moving early steps on a strided subset (coarse_source_points)
//   correspondence search the paper's rule (eq. 2, RegistrationTarget::match), each pair typed by
//                         its residual kind (icp_factors.hpp)
//   robust scale          the kernel's scale from the median residual, per pair group
//   accumulation          the factors' weighted normal equations, chunk by chunk
//   step                  point-to-plane Gauss–Newton, or the point metric's closed form (eq. 1)
//   convergence           stop, search again, or take another step on the same pairs
//   covariance            the sandwich covariance of the last pairs, from the same factors
//
// Determinism: the source is cut into fixed chunks; each chunk's partial sums are computed in
// parallel and added in chunk order, so results do not depend on the number of threads.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

#include "hazmap/core/error.hpp"
#include "hazmap/core/yield_point.hpp"
#include "hazmap/registration/covariance.hpp"
#include "hazmap/registration/registration.hpp"
#include "hazmap/registration/registration_target.hpp"
#include "icp_factors.hpp"
#include "thread_arena.hpp"

namespace hazmap {

const char* toString(Termination t) {
  switch (t) {
    case Termination::NotRun: return "not run";
    case Termination::Converged: return "converged";
    case Termination::MaxIterations: return "max iterations";
    case Termination::EmptySource: return "empty source";
    case Termination::EmptyTarget: return "empty target";
    case Termination::TooFewSourcePoints: return "too few source points";
    case Termination::TooFewCorrespondences: return "too few correspondences";
    case Termination::AllRejected: return "all rejected";
    case Termination::StepNotFinite: return "step not finite";
    case Termination::Diverged: return "diverged";
  }
  return "unknown";
}

namespace {

using detail::CovarianceSums;
using detail::FactorKind;
using detail::RobustKernelAt;
using detail::runWithThreads;
using detail::StepSums;
using detail::TangentMix;

constexpr std::size_t kChunk = 512;
constexpr std::size_t kSearchGrain = 64;
// Gauss–Newton steps on one correspondence set at most (see IcpSolver::iterate).
constexpr int kMaxReuseSteps = 10;

void terminate(RegistrationResult& result, Termination how, std::string reason) {
  result.termination = how;
  result.reason = std::move(reason);
}

struct Corr {
  std::int32_t target = -1;
  float distance2 = 0.0f;
  float residual = 0.0f;  ///< signed point-to-plane distance, or |p − q| for the 3-D factors
  float weight = 1.0f;    ///< class / soft-label weight (robust weight applied later)
  bool cross = false;
  FactorKind kind = FactorKind::Plane;
  std::uint8_t group = 0;  ///< PairGroup
};

// Pairs whose residuals get a robust scale of their own (IcpSolver::estimateRobustScales).
enum PairGroup : std::uint8_t {
  kOrdinaryPair = 0,  ///< point-to-plane on a surface that is not level, or point-to-point
  kPropertyPair = 1,  ///< a property point matched to its own class
  kLevelPair = 2,     ///< point-to-plane on a level surface (floor, ceiling): sees z, roll, pitch only
};

// A target normal within ~26° of the target frame's z is level (tracking's map and scans are
// gravity-up within a few degrees; a ramp of up to ~25° still counts as floor).
constexpr float kLevelNormalZ = 0.9f;

std::vector<char> propertyFlags(const ClassTable& classes) {
  std::vector<char> is_property;
  for (ClassId id : classes.ids()) {
    if (is_property.size() <= id) is_property.resize(std::size_t(id) + 1, 0);
    is_property[id] = classes.isProperty(id);
  }
  return is_property;
}

// Per class: does a same-class pair get the 3-D residual? Only property classes whose labels mark
// their whole extent (ClassInfo::whole_extent), and only with property_point_to_point.
std::vector<char> pointPairFlags(const ClassTable& classes, bool enabled) {
  std::vector<char> point = propertyFlags(classes);
  for (ClassId id : classes.ids()) point[id] = point[id] && enabled && classes.at(id).whole_extent;
  return point;
}

// Source selection: finite points, evenly strided down to `max_points` (0 = all).
std::vector<std::uint32_t> selectSourcePoints(const LabeledCloud& source, std::size_t max_points) {
  std::vector<std::uint32_t> used;
  used.reserve(source.size());
  for (std::size_t i = 0; i < source.size(); ++i)
    if (source.points[i].allFinite()) used.push_back(static_cast<std::uint32_t>(i));
  if (max_points > 0 && used.size() > max_points) {
    std::vector<std::uint32_t> strided(max_points);
    const double step = static_cast<double>(used.size()) / static_cast<double>(max_points);
    for (std::size_t k = 0; k < strided.size(); ++k) strided[k] = used[static_cast<std::size_t>(k * step)];
    used.swap(strided);
  }
  return used;
}

// Inputs no iteration can work with: sets the result's termination and returns true.
bool unusableInputs(std::size_t used, const RegistrationTarget& target, const RegistrationConfig& config,
                    RegistrationResult& result) {
  if (used == 0) {
    terminate(result, Termination::EmptySource, "empty source cloud");
  } else if (target.empty()) {
    terminate(result, Termination::EmptyTarget, "empty target cloud");
  } else if (used < config.min_correspondences) {
    terminate(result, Termination::TooFewSourcePoints,
              "source has only " + std::to_string(used) + " points (min_correspondences = " +
                  std::to_string(config.min_correspondences) + ")");
  } else {
    return false;
  }
  return true;
}

// The point metric's step: the weighted closed form (Horn/Umeyama) q ≈ R p' + t.
Eigen::Isometry3d closedFormStep(const StepSums& total) {
  const Eigen::Vector3d mp = total.sp / total.w, mq = total.sq / total.w;
  const Eigen::Matrix3d C = total.spq / total.w - mp * mq.transpose();  // Σ w p qᵀ, centred
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(C, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0) D(2, 2) = -1;
  const Eigen::Matrix3d Rd = svd.matrixV() * D * svd.matrixU().transpose();
  Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
  delta.linear() = Rd;
  delta.translation() = mq - Rd * mp;
  return delta;
}

// One ICP stage on a selected source: the iteration (search, scale, accumulate, step, check)
// from a start pose, then the statistics and covariance of where it ended.
class IcpSolver {
 public:
  IcpSolver(const LabeledCloud& source, const RegistrationTarget& target, const ClassTable& classes,
            const RegistrationConfig& config, bool use_labels, std::vector<std::uint32_t> used);

  void iterate(const Eigen::Isometry3d& start, RegistrationResult& result);
  const Eigen::Isometry3d& pose() const { return T_; }
  double kernelScale() const { return kernel_[kOrdinaryPair]; }
  bool solved() const { return total_.w > 0.0; }
  void reportCorrespondences(RegistrationResult& result) const;
  void estimateCovariance(RegistrationResult& result) const;

 private:
  bool searchCorrespondences(int iteration, RegistrationResult& result);
  void pair(std::size_t k, const Eigen::Matrix3f& R, const Eigen::Vector3f& t);
  std::size_t estimateRobustScales();
  struct MedianResidual {
    double value;
    bool three_d;  ///< norms of 3-D residuals (else signed 1-D ones)
  };
  template <class InGroup>
  MedianResidual medianResidual(InGroup in_group);
  double kernelFrom(const MedianResidual& m) const;
  StepSums accumulate(bool fresh) const;
  void accumulateChunk(std::size_t chunk, bool fresh, StepSums& s) const;
  std::optional<Eigen::Isometry3d> step(RegistrationResult& result);
  enum class Next { Converged, Search, Reuse };
  Next next(const Eigen::Isometry3d& delta, bool fresh, int& reuse_steps) const;
  RobustKernelAt kernelOf(const Corr& cr) const { return {config_.robust_kernel, kernel_[cr.group]}; }

  const LabeledCloud& source_;
  const RegistrationTarget& target_;
  const LabeledCloud& tc_;
  const ClassTable& classes_;
  const RegistrationConfig& config_;
  // Normals are read raw after the correspondence search, which asked for (and so estimated)
  // every paired point's normal (target.normal: lazy ones are estimated on first use).
  const std::vector<Eigen::Vector3f>& normals_;
  const bool use_labels_, plane_, use_value_, soft_;
  const float mismatch_weight_;
  const double tangent_scale_;
  const std::vector<char> is_property_;
  const std::vector<char> point_pair_;  ///< per class id: an own-class pair gets the 3-D residual
  std::vector<float> class_weight_;  ///< per source class id (1 when off or unknown)
  const std::vector<std::uint32_t> used_;
  const std::size_t n_, chunks_;
  double reach_ = 0.0;
  bool reuse_allowed_ = true;

  std::vector<Corr> corr_;
  mutable std::vector<StepSums> partial_;
  std::vector<float> abs_res_;
  Eigen::Isometry3d T_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_corr_ = Eigen::Isometry3d::Identity();  ///< the pose at which corr_ was computed
  StepSums total_;
  TangentMix mix_;  ///< of the last step (the covariance uses it too)
  double kernel_[3] = {0.0, 0.0, 0.0};  ///< per PairGroup
  bool level_majority_ = false;  ///< level pairs outnumbered the other ordinary pairs (the last search)
};

IcpSolver::IcpSolver(const LabeledCloud& source, const RegistrationTarget& target, const ClassTable& classes,
                     const RegistrationConfig& config, bool use_labels, std::vector<std::uint32_t> used)
    : source_(source), target_(target), tc_(target.cloud()), classes_(classes), config_(config),
      normals_(target.normalsComputed()), use_labels_(use_labels),
      plane_(config.metric == IcpMetric::PointToPlane),
      use_value_(target.usesProperty() && source.hasProperty()),
      soft_(config.use_classes && config.label_mode == LabelMode::Soft),
      mismatch_weight_(soft_ ? static_cast<float>(1.0 - config.label_confidence * config.label_confidence) : 1.0f),
      tangent_scale_(std::sqrt(config.property_tangent_weight)), is_property_(propertyFlags(classes)),
      point_pair_(pointPairFlags(classes, use_labels && config.property_point_to_point)),
      used_(std::move(used)), n_(used_.size()), chunks_((n_ + kChunk - 1) / kChunk),
      corr_(n_), partial_(chunks_) {
  if (config.use_classes && config.use_class_weights) {
    for (ClassId id : classes.ids()) {
      if (class_weight_.size() <= id) class_weight_.resize(std::size_t(id) + 1, 1.0f);
      class_weight_[id] = static_cast<float>(classes.at(id).weight);
    }
  }
  // Farthest used source point from the sensor: a pose change D (source frame) moves every point
  // by at most |t_D| + angle(D)·reach (bounds how far points moved since the last search).
  bool labelled_points = false;
  for (const std::uint32_t i : used_) {
    reach_ = std::max(reach_, static_cast<double>(source.points[i].norm()));
    const ClassId c = source.classes[i];
    labelled_points = labelled_points || (c < is_property_.size() && is_property_[c]);
  }
  // Reused correspondences only without labels in play: the labelled pairs' wide same-class
  // search reacts to small moves, and freezing it cost property ICP accuracy on the simulated
  // tanks run (map error 0.077 → 0.140 m; re-searching just the labelled points oscillated).
  reuse_allowed_ = !(use_labels && labelled_points);
  abs_res_.reserve(n_);
}

// An iteration is one correspondence search followed by Gauss–Newton steps: the first, plus
// reweighting steps on the same correspondences while the points have hardly moved
// (correspondence_reuse_distance; at most kMaxReuseSteps). max_iterations counts searches.
void IcpSolver::iterate(const Eigen::Isometry3d& start, RegistrationResult& result) {
  T_ = T_corr_ = start;
  bool fresh = true;  // search correspondences for this step (else reuse the last ones)
  int it = -1, reuse_steps = 0;
  while (true) {
    yieldPoint();  // between steps: a thread with more urgent work may pause here
    if (fresh) {
      if (++it == config_.max_iterations) break;
      reuse_steps = 0;
      if (!searchCorrespondences(it, result)) return;
    }
    total_ = accumulate(fresh);
    result.iterations = it + 1;
    if (!(total_.w > 0.0))
      return terminate(result, Termination::AllRejected, "all correspondences were rejected by the robust kernel");
    const std::optional<Eigen::Isometry3d> delta = step(result);
    if (!delta) return;
    T_ = normalized(*delta * T_);
    if (!isFinite(T_)) return terminate(result, Termination::Diverged, "the estimate diverged (non-finite transform)");
    const Next what = next(*delta, fresh, reuse_steps);
    if (what == Next::Converged) {
      result.converged = true;
      result.termination = Termination::Converged;
      return;
    }
    fresh = what == Next::Search;
  }
  terminate(result, Termination::MaxIterations,
            "reached max_iterations (" + std::to_string(config_.max_iterations) + ")");
}

// Correspondence search at T and the robust scales of its pairs; false (with the termination
// set) when too few pairs were found. `iteration` numbers the search for that message.
bool IcpSolver::searchCorrespondences(int iteration, RegistrationResult& result) {
  const Eigen::Matrix3f R = T_.linear().cast<float>();
  const Eigen::Vector3f t = T_.translation().cast<float>();
  T_corr_ = T_;
  // The expensive part; each point on its own, so finer grains than the sums' chunks balance
  // the threads better on small sources without changing a bit.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n_, kSearchGrain), [&](const auto& range) {
    for (std::size_t k = range.begin(); k < range.end(); ++k) pair(k, R, t);
  });
  const std::size_t matched = estimateRobustScales();
  if (matched >= config_.min_correspondences) return true;
  terminate(result, Termination::TooFewCorrespondences,
            "only " + std::to_string(matched) + " correspondences at iteration " + std::to_string(iteration + 1) +
                " (min_correspondences = " + std::to_string(config_.min_correspondences) + ")");
  result.iterations = iteration + 1;
  total_ = StepSums{};
  return false;
}

// Source point k (placed with R, t) paired by the paper's rule, its factor kind, the residual
// its robust weight is taken from, and its class weight.
void IcpSolver::pair(std::size_t k, const Eigen::Matrix3f& R, const Eigen::Vector3f& t) {
  const std::uint32_t i = used_[k];
  const Eigen::Vector3f p = R * source_.points[i] + t;
  const ClassId cls = source_.classes[i];
  const float value = use_value_ ? source_.property[i] : std::numeric_limits<float>::quiet_NaN();
  Corr& cr = corr_[k];
  // The previous iteration's partner bounds the search (exact, see costBound).
  // A point no camera saw is no evidence of its class: it pairs without the penalty.
  const bool observed = !use_labels_ || !unobservedPoint(source_, i, cls < is_property_.size() && is_property_[cls]);
  const float bound = target_.costBound(p, cls, cr.target, use_labels_, observed);
  const TargetMatch m =
      use_labels_ ? target_.match(p, cls, value, bound, observed) : target_.nearestAnyClass(p, cls, bound);
  cr.target = static_cast<std::int32_t>(m.index);
  if (m.index < 0) return;
  // A same-class property pair constrains where the labelled patch is, which a plane residual
  // would throw away (a patch lies in its wall): it gets a 3-D residual — when the labels mark
  // the patch's whole extent; a camera's patch is cut where its view ended (ClassInfo::whole_extent).
  const bool own_property = use_labels_ && !m.cross_class && is_property_[cls];
  const bool point3 = !plane_ || (own_property && point_pair_[cls]);
  const Eigen::Vector3f& nq = plane_ ? target_.normal(m.index) : p;  // p: unused
  const bool anisotropic = plane_ && point3 && tangent_scale_ < 1.0 && !nq.isZero();
  cr.kind = anisotropic ? FactorKind::PropertyPair : point3 ? FactorKind::Point : FactorKind::Plane;
  cr.group = own_property ? kPropertyPair
             : plane_ && std::abs(nq.z()) > kLevelNormalZ ? kLevelPair
                                                          : kOrdinaryPair;
  if (anisotropic) {
    cr.residual = detail::weightedResidual(p - tc_.points[m.index], nq, tangent_scale_).norm();
  } else if (!point3) {
    if (nq.isZero()) {  // no normal there: unusable for point-to-plane
      cr.target = -1;
      return;
    }
    cr.residual = nq.dot(p - tc_.points[m.index]);
  } else {
    cr.residual = std::sqrt(m.distance2);
  }
  cr.distance2 = m.distance2;
  cr.cross = m.cross_class;
  cr.weight = use_labels_ && cls < class_weight_.size() ? class_weight_[cls] : 1.0f;
  if (m.cross_class && !m.unobserved && soft_ && use_labels_) cr.weight *= mismatch_weight_;
}

// Adaptive robust scale from the observed residuals (median absolute residual), separately for
// ordinary pairs and for property pairs (few, larger residuals, and the ones that carry the
// label's information — one shared scale would silence them). Ordinary pairs share one scale
// unless level pairs are most of them *and* the others' median residual lies beyond that
// kernel, i.e. most of the others would count as outliers; the others then get their own scale.
// In an open field seen from a low sensor the floor is 77–87 % of the pairs and its residuals are
// near zero whatever the error in x, y and yaw: the shared kernel was the floor's noise and
// rejected the pairs that see the horizontal (tanks: tracking stayed at the wheels' guess, map
// error 0.18–1.07 m). A hall whose floor is a bare majority keeps the shared scale: its walls fit
// it, and scaling them apart only let more outliers in (docs/history/2026-12-06-open-field-robust-scale.md).
// Returns the number of pairs.
std::size_t IcpSolver::estimateRobustScales() {
  std::size_t level = 0, other = 0, property = 0;
  for (const Corr& cr : corr_) {
    if (cr.target < 0) continue;
    level += cr.group == kLevelPair;
    other += cr.group == kOrdinaryPair;
    property += cr.group == kPropertyPair;
  }
  const auto ordinary = [](const Corr& cr) { return cr.group != kPropertyPair; };
  if (level + other > 0) kernel_[kOrdinaryPair] = kernel_[kLevelPair] = kernelFrom(medianResidual(ordinary));
  level_majority_ = level > other;
  if (level_majority_ && other > 0) {
    const MedianResidual others = medianResidual([](const Corr& cr) { return cr.group == kOrdinaryPair; });
    if (others.value > kernel_[kOrdinaryPair]) kernel_[kOrdinaryPair] = kernelFrom(others);
  }
  if (property > 0) kernel_[kPropertyPair] = kernelFrom(medianResidual([](const Corr& cr) { return cr.group == kPropertyPair; }));
  return level + other + property;
}

// The median absolute residual of the matched pairs `in_group` selects (at least one).
template <class InGroup>
IcpSolver::MedianResidual IcpSolver::medianResidual(InGroup in_group) {
  abs_res_.clear();
  bool p3 = !plane_;
  for (const Corr& cr : corr_)
    if (cr.target >= 0 && in_group(cr)) {
      abs_res_.push_back(std::abs(cr.residual));
      p3 = detail::isPointFactor(cr.kind);
    }
  const std::size_t mid = abs_res_.size() / 2;
  std::nth_element(abs_res_.begin(), abs_res_.begin() + mid, abs_res_.end());
  return {abs_res_[mid], p3};
}

// The kernel's scale: robust_scale_factor σ̂, σ̂ from a median absolute residual.
double IcpSolver::kernelFrom(const MedianResidual& m) const {
  // |r| of a 1-D Gaussian has median 0.6745σ; the norm of a 3-D one 1.5382σ.
  const double sigma = m.value / (m.three_d ? 1.5382 : 0.6745);
  return std::max(config_.robust_min_scale, config_.robust_scale_factor * sigma);
}

// The weighted normal equations at the current pose, chunk by chunk, added in chunk order.
StepSums IcpSolver::accumulate(bool fresh) const {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks_, 1), [&](const auto& range) {
    for (std::size_t c = range.begin(); c < range.end(); ++c) accumulateChunk(c, fresh, partial_[c]);
  });
  StepSums total;
  for (const StepSums& s : partial_) total.add(s);
  return total;
}

// Residuals and robust weights at the current pose: the searched ones on a fresh iteration,
// recomputed when the correspondences are reused. Flattened: GCC otherwise leaves the factors'
// 6x6 updates as out-of-line calls, slower than the unsplit ICP's loop (docs/measurements.md).
[[gnu::flatten]] void IcpSolver::accumulateChunk(std::size_t chunk, bool fresh, StepSums& out) const {
  StepSums s;
  const std::size_t end = std::min(n_, (chunk + 1) * kChunk);
  for (std::size_t k = chunk * kChunk; k < end; ++k) {
    const Corr& cr = corr_[k];
    if (cr.target < 0) continue;
    const Eigen::Vector3d p = T_ * source_.points[used_[k]].cast<double>();
    const Eigen::Vector3d q = tc_.points[cr.target].cast<double>();
    double residual = cr.residual;
    if (!fresh) {
      if (cr.kind == FactorKind::PropertyPair)
        residual = detail::weightedResidual((p - q).cast<float>(), normals_[cr.target], tangent_scale_).norm();
      else if (cr.kind == FactorKind::Plane)
        residual = normals_[cr.target].cast<double>().dot(p - q);
      else
        residual = (p - q).norm();
    }
    const double w = cr.weight * kernelOf(cr).weight(residual);
    ++s.n;
    s.d2 += cr.distance2;
    if (!(w > 0.0)) continue;
    detail::withFactor(cr.kind, p, q, normals_, cr.target, residual, config_.property_tangent_weight,
                       [&](const auto& factor) { factor.addToStep(s, w); });
    if (cr.kind != FactorKind::Plane) s.addPointPair(w, p, q);
    s.w += w;
  }
  out = s;
}

// The pose update: point-to-plane Gauss–Newton (property pairs' in-plane parts mixed in), or the
// point metric's closed form. nullopt (with the termination set) when the step is not finite.
std::optional<Eigen::Isometry3d> IcpSolver::step(RegistrationResult& result) {
  if (!plane_) return closedFormStep(total_);
  mix_ = TangentMix(total_.H, total_.w, config_.property_tangent_weight, config_.degeneracy_length,
                    config_.degeneracy_threshold);
  Matrix6d A = total_.H + mix_(total_.Ht);
  total_.g += mix_(total_.gt);
  A.diagonal().array() += 1e-9 * std::max(1.0, A.trace() / 6.0);  // guards exact degeneracy
  const Vector6d xi = A.ldlt().solve(-total_.g);
  if (!xi.allFinite()) {
    terminate(result, Termination::StepNotFinite, "the Gauss-Newton step was not finite");
    return std::nullopt;
  }
  return se3Exp(xi);
}

// Converged when the step is below the tolerances on fresh correspondences (on reused ones:
// check against fresh ones first). Otherwise reuse the pairs while the points have hardly moved.
IcpSolver::Next IcpSolver::next(const Eigen::Isometry3d& delta, bool fresh, int& reuse_steps) const {
  const double dt = delta.translation().norm();
  const double dr = rotationAngle(delta);
  if (dt < config_.translation_tolerance && dr < config_.rotation_tolerance)
    return fresh ? Next::Converged : Next::Search;
  const Eigen::Isometry3d moved = T_corr_.inverse() * T_;
  const bool search = !reuse_allowed_ || ++reuse_steps > kMaxReuseSteps ||
                      !(moved.translation().norm() + rotationAngle(moved) * reach_ < config_.correspondence_reuse_distance);
  return search ? Next::Search : Next::Reuse;
}

// Statistics of the last correspondence set.
void IcpSolver::reportCorrespondences(RegistrationResult& result) const {
  std::size_t matched = 0, cross = 0, prop = 0, prop_matched = 0, wide = 0;
  const double r0 = config_.max_correspondence_distance;
  for (std::size_t k = 0; k < n_; ++k) {
    const bool is_prop = classes_.isProperty(source_.classes[used_[k]]);
    prop += is_prop;
    if (corr_[k].target < 0) continue;
    ++matched;
    cross += corr_[k].cross;
    if (is_prop && !corr_[k].cross) {
      ++prop_matched;
      wide += corr_[k].distance2 > r0 * r0;
    }
  }
  result.stats.matched = matched;
  result.stats.cross_class = cross;
  result.stats.same_class = matched - cross;
  result.stats.property_points = prop;
  result.stats.property_matched = prop_matched;
  result.stats.wide_matches = wide;
  result.fitness = static_cast<double>(matched) / static_cast<double>(n_);
  result.inlier_rmse = total_.n > 0 ? std::sqrt(total_.d2 / static_cast<double>(total_.n)) : 0.0;
}

// Covariance pass over the last correspondences (serial: cheap, and it needs per-target sums).
// The meat is cluster-robust: residuals that share a target point share that point's noise, so
// their score contributions are summed per target point before the outer product.
void IcpSolver::estimateCovariance(RegistrationResult& result) const {
  CovarianceSums sums;
  // Per target point, reused across calls: a target-sized buffer zeroed per ICP cost more than
  // the pass itself when a few hundred points register against a local map (the motion
  // hypotheses' refinements). Entries outside `touched` stay zero between calls.
  thread_local std::vector<Vector6d> per_target;
  thread_local std::vector<char> seen;
  thread_local std::vector<std::uint32_t> touched;
  if (per_target.size() < tc_.size()) {
    per_target.resize(tc_.size(), Vector6d::Zero());
    seen.resize(tc_.size(), 0);
  }
  touched.clear();
  double level_weight = 0.0;
  for (std::size_t k = 0; k < n_; ++k) {
    const Corr& cr = corr_[k];
    if (cr.target < 0) continue;
    const RobustKernelAt kernel = kernelOf(cr);
    const double w = cr.weight * kernel.weight(cr.residual);
    if (!(w > 0.0)) continue;
    const Eigen::Vector3d p = T_corr_ * source_.points[used_[k]].cast<double>();
    const Eigen::Vector3d q = tc_.points[cr.target].cast<double>();
    detail::withFactor(cr.kind, p, q, normals_, cr.target, cr.residual, config_.property_tangent_weight,
                       [&](const auto& factor) { per_target[cr.target] += factor.addToCovariance(sums, w, kernel, mix_); });
    sums.pairs += w;
    if (cr.group == kLevelPair) level_weight += w;
    if (!seen[cr.target]) touched.push_back(static_cast<std::uint32_t>(cr.target));
    seen[cr.target] = 1;
  }
  // The meat in target order, as a pass over every target point would add it.
  std::sort(touched.begin(), touched.end());
  Matrix6d meat = Matrix6d::Zero();
  for (const std::uint32_t j : touched) meat.noalias() += per_target[j] * per_target[j].transpose();
  for (const std::uint32_t j : touched) {  // only these were written
    per_target[j].setZero();
    seen[j] = 0;
  }
  const Matrix6d bread = sums.bread + mix_(sums.bread_t);
  const Matrix6d H = total_.H + mix_(total_.Ht);
  // Degenerate = a direction below degeneracy_threshold of the pairs' weight. Where level pairs
  // are most of the pairs they would make x, y and yaw look degenerate by their number alone —
  // they constrain only z, roll and pitch — so the share is taken of the others' weight there.
  const double judged_weight = level_majority_ ? sums.pairs - level_weight : sums.pairs;
  const PoseCovariance pc = poseCovariance(H, bread, meat, sums.wr2, sums.components, judged_weight,
                                           config_.degeneracy_length, config_.degeneracy_threshold);
  result.hessian = H;
  result.covariance = pc.covariance;
  result.residual_sigma = pc.residual_sigma;
  result.degenerate_directions = pc.degenerate_directions;
  result.label_only_directions = mix_.directions;
}

RegistrationResult solve(const LabeledCloud& source, const RegistrationTarget& target,
                         const Eigen::Isometry3d& initial_guess, const ClassTable& classes,
                         const RegistrationConfig& config, bool use_labels, bool covariance = true);

// Coarse to fine (coarse_source_points): the far-moving early steps on a strided subset, then
// the full source from where they ended. A coarse stage that failed leaves the guess as it was.
Eigen::Isometry3d coarseStart(const LabeledCloud& source, const RegistrationTarget& target,
                              const Eigen::Isometry3d& initial_guess, const ClassTable& classes,
                              const RegistrationConfig& config, bool use_labels, std::size_t used,
                              RegistrationResult& result) {
  if (config.coarse_source_points == 0 || used < 4 * config.coarse_source_points) return initial_guess;
  RegistrationConfig coarse = config;
  coarse.coarse_source_points = 0;
  coarse.max_source_points = config.coarse_source_points;
  coarse.translation_tolerance = 10.0 * config.translation_tolerance;
  coarse.rotation_tolerance = 10.0 * config.rotation_tolerance;
  // Only its pose is used: no covariance pass (a serial loop and a target-sized buffer).
  const RegistrationResult c = solve(source, target, initial_guess, classes, coarse, use_labels,
                                     /*covariance=*/false);
  result.coarse_iterations = c.iterations;
  const bool usable = c.converged || c.termination == Termination::MaxIterations;
  return usable && isFinite(c.transform) ? c.transform : initial_guess;
}

// One ICP run (with its coarse stage). `covariance` = false leaves the result's covariance,
// Hessian and degenerate directions at their "unknown" defaults.
RegistrationResult solve(const LabeledCloud& source, const RegistrationTarget& target,
                         const Eigen::Isometry3d& initial_guess, const ClassTable& classes,
                         const RegistrationConfig& config, bool use_labels, bool covariance) {
  RegistrationResult result;
  result.transform = initial_guess;
  result.covariance = Matrix6d::Identity() * 1e6;  // "unknown" until a solution exists
  std::vector<std::uint32_t> used = selectSourcePoints(source, config.max_source_points);
  result.stats.source_points = used.size();
  if (unusableInputs(used.size(), target, config, result)) return result;

  const Eigen::Isometry3d start =
      coarseStart(source, target, initial_guess, classes, config, use_labels, used.size(), result);
  result.labels_used = use_labels;
  IcpSolver icp(source, target, classes, config, use_labels, std::move(used));
  runWithThreads(config.threads, [&] { icp.iterate(start, result); });
  result.transform = isFinite(icp.pose()) ? icp.pose() : start;
  result.kernel_scale = icp.kernelScale();
  icp.reportCorrespondences(result);
  if (covariance && icp.solved()) icp.estimateCovariance(result);
  return result;
}

// Label gate: do the labels agree with the target's where the geometry pairs points up? Each
// labelled source point (placed with T) is paired with its nearest target point of any class;
// the agreement rate is corrected for chance (Cohen's κ against the target's class shares).
// Random labels give κ ≈ 0. NaN with fewer than min_label_pairs pairs.
double labelAgreement(const LabeledCloud& source, const RegistrationTarget& target,
                      const Eigen::Isometry3d& T, const std::vector<char>& is_property,
                      std::size_t min_pairs) {
  std::vector<double> share;
  std::size_t paired = 0;
  double agree = 0.0, chance = 0.0;
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  for (std::size_t i = 0; i < source.size(); ++i) {
    const ClassId cls = source.classes[i];
    if (cls >= is_property.size() || !is_property[cls] || !source.points[i].allFinite()) continue;
    const TargetMatch m = target.nearestAnyClass(R * source.points[i] + t, cls);
    if (m.index < 0 || m.unobserved) continue;  // no sensor saw that target point: no evidence
    if (share.size() <= cls) share.resize(std::size_t(cls) + 1, -1.0);
    if (share[cls] < 0.0) share[cls] = target.classShare(cls);
    ++paired;
    agree += !m.cross_class;
    chance += share[cls];
  }
  if (paired < std::max<std::size_t>(min_pairs, 1)) return std::numeric_limits<double>::quiet_NaN();
  const double a = agree / static_cast<double>(paired), e = chance / static_cast<double>(paired);
  return e < 1.0 ? (a - e) / (1.0 - e) : 1.0;
}

}  // namespace

RegistrationResult registerClouds(const LabeledCloud& source, const LabeledCloud& target,
                                  const Eigen::Isometry3d& initial_guess, const ClassTable& classes,
                                  const RegistrationConfig& config) {
  config.validate();
  if (!isFinite(initial_guess)) fail("registration", "initial guess has a non-finite entry");
  RegistrationResult result;
  runWithThreads(config.threads, [&] {
    const RegistrationTarget prepared(target, classes, config);
    result = registerClouds(source, prepared, initial_guess, classes, config);
  });
  return result;
}

// The label gate around the solver. Labels agreeing at the initial guess are trusted outright.
// Otherwise the guess may simply be off by more than a patch (exactly when labels help), so the
// labelled solution is checked where it landed: labels that still disagree there are noise, and
// the registration is redone without them (plain ICP) — property ICP degrades to plain ICP
// instead of being pulled wherever wrong labels happen to cluster.
RegistrationResult registerClouds(const LabeledCloud& source, const RegistrationTarget& target,
                                  const Eigen::Isometry3d& initial_guess, const ClassTable& classes,
                                  const RegistrationConfig& config) {
  config.validate();
  if (!isFinite(initial_guess)) fail("registration", "initial guess has a non-finite entry");
  source.checkConsistent("registration source");
  if (config.use_classes) classes.checkCloud(source, "registration source");
  if (!target.compatibleWith(config, classes))
    fail("registration", "the prebuilt target was built with a different configuration or class table");
  if (!config.use_classes) return solve(source, target, initial_guess, classes, config, false);
  if (config.min_label_agreement <= -1.0) return solve(source, target, initial_guess, classes, config, true);

  const std::vector<char> is_property = propertyFlags(classes);
  const double before = labelAgreement(source, target, initial_guess, is_property, config.min_label_pairs);
  RegistrationResult labelled = solve(source, target, initial_guess, classes, config, true);
  labelled.label_agreement = before;
  if (std::isnan(before) || before >= config.min_label_agreement) return labelled;
  const double after = labelAgreement(source, target, labelled.transform, is_property, config.min_label_pairs);
  labelled.label_agreement = after;
  if (std::isnan(after) || after >= config.min_label_agreement) return labelled;
  RegistrationResult plain = solve(source, target, initial_guess, classes, config, false);
  plain.label_agreement = after;
  return plain;
}

}  // namespace hazmap
