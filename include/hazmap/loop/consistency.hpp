#pragma once
// Rejection of false loops, complementary to the robust loss the pose graph puts on loop edges.
//
//  1. Drift gate: a verified loop's relative pose is compared with the relative pose of the two
//     keyframes in the current estimate. Their difference is gated by a χ² test on its
//     Mahalanobis distance under the loop's ICP covariance plus the drift the estimate can have
//     accumulated along the trajectory between the keyframes (σ = floor + rate · path length).
//     Far-apart loops (much drift) therefore pass even when metres off; a loop between
//     keyframes close in time must agree closely.
//  2. Pairwise consistency (as in PCM, Mangelson et al. 2018): loops i→j and k→l are consistent
//     when the cycle  loop_ij⁻¹ · est_ik · loop_kl · est_lj  is the identity within the drift of
//     the short paths i…k and l…j. Only the largest mutually consistent set is kept, so a
//     wrong loop must agree with every other loop to survive.
#include <cstddef>
#include <memory>
#include <vector>

#include "hazmap/loop/candidates.hpp"
#include "hazmap/loop/verification.hpp"

namespace hazmap {

struct ConsistencyConfig {
  /// Drift model of the pose estimate between two keyframes, as standard deviations per metre
  /// of path travelled, plus floors (constants in src/loop/consistency.cpp). Defaults sized for
  /// the crawler's odometry (issue 3: ~5 % distance error plus slips, ~0.25° yaw per metre):
  /// conservative, so that the gate rejects only clearly impossible loops. Every verified loop
  /// is gated, and only the largest pairwise-consistent set is kept.
  double translation_drift_per_metre = 0.04;
  double rotation_drift_per_metre = 0.004;  ///< rad/m (≈ 0.23°/m)
  /// Probability of the χ² gates (6 degrees of freedom): 0.999 → d² ≤ 22.46.
  double gate_probability = 0.999;
};

struct GateResult {
  bool accepted = false;
  double mahalanobis2 = 0.0;  ///< d² of the loop against the estimate
  double threshold = 0.0;     ///< χ² quantile used
  double path_length = 0.0;   ///< m, along the estimate between the keyframes
};

/// Path length (m) along `poses` between keyframes a and b (either order).
double pathLength(const PoseList& poses, std::size_t a, std::size_t b);

/// Drift covariance (translation-first, diagonal) for a path of the given length.
Matrix6d driftCovariance(double path_length, const ConsistencyConfig& config);

/// χ² quantile for 3 or 6 degrees of freedom at probability p in (0, 1) (closed-form CDF, bisection).
double chiSquareQuantile(int dof, double p);

/// Gate 1: the loop against the current estimate `poses` (world ← keyframe).
GateResult driftGate(const LoopClosure& loop, const PoseList& poses, const ConsistencyConfig& config = {});

/// Squared Mahalanobis distance of the cycle formed by two loops and the estimate.
/// The calibrated innovation gate (issue 14): the loop against the estimate's relative pose of
/// its keyframes, d² = eᵀ (Σ_loop + Σ_rel)⁻¹ e ≤ χ²₆(probability), where Σ_rel is the covariance
/// the pose graph itself gives that relative pose (its odometry edges' calibrated covariances
/// composed along the path, `relative_covariance`, left perturbation in the `from` frame). A loop
/// that disagrees with the tracking by more than both their honest uncertainties is wrong.
GateResult innovationGate(const LoopClosure& loop, const PoseList& poses, const Matrix6d& relative_covariance,
                          double probability);
double pairwiseDistance2(const LoopClosure& a, const LoopClosure& b, const PoseList& poses,
                         const ConsistencyConfig& config = {});

/// Indices (ascending) of the largest pairwise-consistent subset of `loops` (exact maximum
/// clique for up to 64 loops, greedy beyond). Ties prefer the subset with the smaller summed
/// drift-gate distance. Every loop is consistent with itself, so one loop is kept as is.
std::vector<std::size_t> consistentSubset(const std::vector<LoopClosure>& loops, const PoseList& poses,
                                          const ConsistencyConfig& config = {});

/// consistentSubset for a list of loops that grows call by call (a long mission revisiting its
/// route closes a loop at nearly every keyframe, and the back end asks before every
/// optimisation). Up to 64 loops each call is consistentSubset itself: exact, every pair tested
/// under the estimate given. Beyond, where the subset is greedy anyway, a pair is tested once,
/// under the estimate of the call that first sees both loops, and remembered: a call costs
/// O(new loops × loops) pair tests instead of O(loops²), which grew into most of the back end's
/// time after ~500 loops (docs/loop_closure.md). The pairwise test reads only the estimate's short
/// relative paths between the loops' ends, which later optimisations move by far less than the
/// drift the test allows them. Loops may be forgotten between calls (an order-keeping erase, as
/// LoopDetector::dropLoop); the others keep their tests.
class IncrementalConsistency {
 public:
  explicit IncrementalConsistency(ConsistencyConfig config = {});
  ~IncrementalConsistency();
  IncrementalConsistency(IncrementalConsistency&&) noexcept;
  IncrementalConsistency& operator=(IncrementalConsistency&&) noexcept;

  /// Indices (ascending) of the largest pairwise-consistent subset of `loops`, as consistentSubset.
  std::vector<std::size_t> subset(const std::vector<LoopClosure>& loops, const PoseList& poses);
  /// Pair tests made so far (by all calls), for benchmarks and tests.
  std::size_t pairTests() const;

 private:
  struct Remembered;
  ConsistencyConfig config_;
  std::unique_ptr<Remembered> remembered_;
  std::size_t pair_tests_ = 0;
};

void validate(const ConsistencyConfig& config);

}  // namespace hazmap
