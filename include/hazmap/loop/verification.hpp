#pragma once
// Loop verification (paper section V): property-aware ICP from the candidate's initial guess;
// the loop is accepted only if the registration converged, fits well, and its covariance is
// well conditioned and small. The loop edge's information matrix is the inverse of the ICP
// covariance (eq. 3, Σ_{u,t}⁻¹).
#include <Eigen/Geometry>
#include <string>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/loop/candidates.hpp"
#include "hazmap/registration/registration.hpp"

namespace hazmap {

/// The size (m) of a small pose change d wherever one distance bounds it (full_from_coarse_within,
/// LoopClosureConfig::submap_reuse_tolerance): translation + a 10 m lever × rotation angle.
inline double poseChangeSize(const Eigen::Isometry3d& d) {
  constexpr double lever = 10.0;  // m
  return translationNorm(d) + lever * rotationAngle(d);
}

class RegistrationTarget;

/// What loop verification's ICP changes from the tracking ICP (odometry.registration), and only
/// that (issue 37: overrides, not a copy): every other setting — metric, robust kernel, labels,
/// tolerances, use_classes — is tracking's.
struct VerificationIcpOverrides {
  /// Loops start farther from the truth than odometry steps: a wider correspondence distance.
  double max_correspondence_distance = 1.5;
  int max_iterations = 60;
  /// At most 6000 source points (evenly strided): enough to verify a loop and bounded in time.
  std::size_t max_source_points = 6000;
  /// Dense keyframes (0.15 m voxels) searched 1.5 m wide: a voxel hash with 1.5 m cells scans
  /// ~100 points per cell; the k-d tree verifies the same loops faster (docs/measurements.md).
  SpatialIndexKind index = SpatialIndexKind::KdTree;
  /// Single stage: the acceptance thresholds below were set on single-stage results, and a
  /// loop's larger initial error is where a 1000-point coarse stage could settle elsewhere
  /// (on naraha it accepted 18 loops instead of 16, map error +4 mm).
  std::size_t coarse_source_points = 0;
  /// `tracking` with these fields replaced.
  RegistrationConfig over(RegistrationConfig tracking) const;
};

struct VerificationConfig {
  /// The verification ICP = tracking's with these overrides (property-aware by default;
  /// tracking's use_classes = false for the conventional baselines).
  VerificationIcpOverrides registration;
  /// Not a key: the tracking ICP the overrides apply to. The pipeline sets it to
  /// odometry.registration (loopClosureConfigFor); a standalone loop detector keeps the
  /// default, which is tracking's default.
  RegistrationConfig tracking_registration;
  /// The ICP verification runs: tracking_registration with the overrides.
  RegistrationConfig icp() const { return registration.over(tracking_registration); }
  /// Fraction of source points with a correspondence. Keyframes of one place from 1–3 m apart
  /// reach 0.93–1.0 on simulated VLP-16 data; wrong alignments often 0.7–0.9.
  double min_fitness = 0.8;
  /// Inlier RMSE (m). Loose: two sparse VLP-16 scans of one place from 1–3 m apart have
  /// 0.25–0.4 m even when aligned (the rings hit different spots), so this only catches gross
  /// misalignment; the covariance and consistency checks do the rest.
  double max_rmse = 0.4;
  /// Reject loops whose registration reported a degenerate direction (a corridor: the loop
  /// would constrain nothing along it and pull the graph by an arbitrary amount).
  bool reject_degenerate = true;
  /// ICP may move the pose at most this far from the initial guess (m, rad); farther means it
  /// slid into another local minimum (e.g. the neighbouring identical tank).
  double max_correction_translation = 2.0;
  double max_correction_rotation = 0.35;
  /// Calibration of the loop covariance against the simulator's truth (issue 14, NEES):
  /// Σ_loop = covariance_scale · Σ_ICP + diag(floor²). docs/pose_graph.md has the fit.
  double covariance_scale = 1.0;
  /// Honest loop covariance (issue 14). The sandwich ICP covariance treats the residuals as
  /// independent noise; two scans of one place from different viewpoints differ systematically
  /// (different rings, different ranges), which does not average out over thousands of pairs. The
  /// loops that passed every test and pulled maps off (naraha: 11–12 m baselines, 4–5.6 cm /
  /// 6.5–8 mrad off while claiming 1.5 cm / 1.1 mrad) have a large misfit and a weak Hessian, so
  /// the Gauss–Newton covariance of the whole misfit, inlier_rmse² · H⁻¹, is added: it carries
  /// the Hessian's weak axis with the misfit the registration actually has. This is its weight
  /// (0 = off).
  double misfit_scale = 1.0;
  /// Cross-check of the misfit term (issue 14): the loop is registered again the other way — the
  /// match keyframe's submap onto the query keyframe and the keyframes before it
  /// (LoopClosureConfig::cross_check_query_keyframes), from the inverse of the candidate's guess;
  /// when the two answers agree to within this χ² (6 dof, against twice the forward ICP covariance
  /// plus the floors) the loop keeps its full information and the misfit term is not added. A loop
  /// with a label-only direction always keeps the term. 0 = off (the misfit term is always added).
  /// With single scans on the reverse side (first version) naraha 2's wrong 22→152 (4 cm off)
  /// agreed at d² = 8.3 and right 180° loops disagreed (d² 11–60); submap against submap, the wrong
  /// long-baseline loops of naraha 1–6 give d² 15–940 and the right ones ≤ 4 but for 8 of 185
  /// (docs/pose_graph.md, sixth shift).
  double cross_check_chi2 = 4.0;
  /// Along a direction the geometry leaves degenerate and only labelled patches constrain
  /// (RegistrationResult::label_only_directions: a featureless corridor's axis), the loop knows
  /// its position only to where two scans happened to sample the patches: this standard
  /// deviation (m; rad per degeneracy_length m for rotations) is added along it. On the
  /// corridor the loops were 3–76 cm off along its axis while claiming 1–4.5 cm (RMS 34 cm), but
  /// σ = 0.35 m still let them pull the graph there (its frame-to-map edges know the axis no
  /// better): the default makes a loop carry no information along such a direction, so only the
  /// directions the geometry constrains are closed. 0 = off.
  double label_only_sigma = 100.0;
  /// Basin probes: an accepted loop is registered again from its result shifted by ±probe_distance
  /// along the match frame's x and y; the spread of where those runs land (their sample covariance
  /// around the result) is added to the loop covariance. A repetitive corridor or a row of tanks
  /// lets ICP settle in a neighbouring basin with a sharp Hessian covariance; the probes expose
  /// that ambiguity, which the Hessian cannot. 0 = off.
  double probe_distance = 0.2;
  /// Coarse check before the full verification ICP: the same registration with at most this many
  /// source points; a candidate whose coarse fitness stays below min_fitness − coarse_fitness_margin
  /// is rejected (low fitness) without the full run. Most candidates are wrong places with
  /// fitness 0.3–0.7, and the full ICP is the loop stage's main cost. 0 = off.
  std::size_t coarse_source_points = 1000;
  /// The coarse fitness (1000 of ≈ 5500 points) predicted the full run's within ±0.02 on naraha 1
  /// (60 pairs, σ of a 1000-point fraction ≈ 0.013); 0.04 is 3σ. It was 0.1 before 2026-12-02:
  /// candidates at 0.70–0.76 then ran the full ICP to fail min_fitness (0.8) there. Since
  /// 2026-12-02 every frame-to-map and frame-to-frame run of the sweep gives the same trajectory
  /// bit for bit (docs/pose_graph.md, "Online cost, fourth pass").
  double coarse_fitness_margin = 0.04;
  /// Before the coarse check (online cost, issue 14): the fitness of this many source points at
  /// the candidate's guess, one correspondence search and no ICP; a candidate below the coarse
  /// floor (min_fitness − coarse_fitness_margin) minus a margin (verify_icp.cpp) is rejected (low
  /// fitness) without the coarse ICP. ICP raised the fitness by at most 0.18 from the guess on
  /// naraha, corridor and tanks (seed 1, 233 candidates). 0 = off.
  std::size_t guess_check_points = 300;
  /// Online cost (issue 14): the full verification ICP starts where the coarse check converged
  /// (its 1000-point answer) instead of at the candidate's guess again, so it only refines — but
  /// only when that answer lies within this distance of the guess (m, translation + 10 m ×
  /// rotation). Along a weakly constrained direction the full source's ICP stops wherever its
  /// start leaves it: refining every coarse answer, the heavy-drift test
  /// (LoopVerify.DetectorClosesTheRouteLoopUnderDrift) accepted 3→60 beyond 0.1 m / 0.01 rad of
  /// the truth, from a coarse answer 0.14 m and 8 mrad (0.23 in this measure) from its guess; at
  /// 0.5 it still does. The default is the basin probes' distance, whose probes then test the
  /// start's neighbourhood. Naraha 1: 24 of 43 full runs refine, their searches 501 → 391; every
  /// accuracy rule held on the 64-run sweep (docs/pose_graph.md, "Online cost, fifth pass").
  /// 0 = always from the guess.
  double full_from_coarse_within = 0.2;
  /// Online cost (issue 14): the basin probes and the reverse cross-check run a coarse stage of
  /// this many source points (RegistrationConfig::coarse_source_points: the far-moving first steps
  /// on a strided subset, tolerances 10× looser) before the full source refines where it ended;
  /// the probe's answer is still the full source's. 0 = single stage.
  /// Default since 2026-12-02 with probe_tolerance_scale 10: every accuracy rule held on naraha,
  /// corridor and tanks (seeds 1–8) and in the paper's set-up (docs/pose_graph.md, "Online cost").
  std::size_t probe_coarse_points = 1000;
  /// Online cost (issue 14): the basin probes stop at the registration's translation and rotation
  /// tolerances times this. A probe only tells which basin it lands in; its last creeping steps
  /// (sub-millimetre, against a 5 cm spread limit and a 1 cm floor on the loop's σ) are most of
  /// its iterations. 1 = the verification's tolerances.
  double probe_tolerance_scale = 10.0;
};

/// An accepted loop: an edge from the past keyframe `from` to the current keyframe `to`.
struct LoopClosure {
  std::size_t from = 0;  ///< the past keyframe (candidate.match)
  std::size_t to = 0;    ///< the current keyframe (candidate.query)
  Eigen::Isometry3d T_from_to = Eigen::Isometry3d::Identity();  ///< from ← to (ICP result)
  Matrix6d covariance = Matrix6d::Identity();   ///< translation-first, floored
  Matrix6d information = Matrix6d::Identity();  ///< covariance⁻¹
  CandidateSource source = CandidateSource::Constellation;
  double fitness = 0.0;
  double rmse = 0.0;
};

/// Why a loop candidate was rejected (VerificationResult::reason says it for people).
enum class LoopRejection {
  None,                   ///< accepted (or not yet verified)
  EmptyCloud,             ///< a keyframe cloud was empty
  NotConverged,           ///< the registration did not converge
  NonFinite,              ///< non-finite pose or covariance
  LowFitness,             ///< fitness below min_fitness
  HighRmse,               ///< inlier RMSE above max_rmse
  Degenerate,             ///< a degenerate direction (reject_degenerate)
  LargeCorrection,        ///< ICP moved beyond max_correction_* from the guess
  CovarianceNotPositive,  ///< the covariance is not positive definite
  UncertainTranslation,   ///< translation sigma above the bound (verification.cpp)
  UncertainRotation,      ///< rotation sigma above the bound (verification.cpp)
  DriftGate,              ///< verified, then rejected by the drift gate (LoopDetector)
  InnovationGate,         ///< verified, then rejected by the calibrated χ² innovation gate
  Ambiguous,              ///< basin probes landed elsewhere (verify_icp.cpp, kMaxProbeSpread)
  Inconsistent,           ///< not in the largest pairwise-consistent set
  OptimisationFailed,     ///< the graph with this loop could not be solved (previous estimate kept)
  OptimisationDiverged,   ///< the solution with this loop moved poses beyond belief (dropped)
};
const char* toString(LoopRejection rejection);

struct VerificationResult {
  bool accepted = false;
  LoopRejection rejection = LoopRejection::None;
  std::string reason;  ///< why it was rejected, for people (empty when accepted)
  LoopClosure closure;
  RegistrationResult registration;
};

/// The acceptance rules applied to a finished registration of `candidate` (source = query
/// keyframe, target = match keyframe). Pure; no ICP is run.
VerificationResult evaluateRegistration(const LoopCandidate& candidate,
                                        const RegistrationResult& registration,
                                        const VerificationConfig& config = {});

/// What the loop covariance adds to the (scaled) ICP covariance to be honest
/// (VerificationConfig::misfit_scale, label_only_sigma): misfit_scale · inlier_rmse² · H⁻¹, and
/// label_only_sigma² along each of the registration's label-only directions. Translation first.
Matrix6d honestyTerms(const RegistrationResult& registration, const VerificationConfig& config = {});
/// The misfit part of honestyTerms alone: misfit_scale · inlier_rmse² · H⁻¹ (0 when off).
Matrix6d misfitTerm(const RegistrationResult& registration, const VerificationConfig& config = {});
/// The floor variances every loop covariance carries (verification.cpp: kMinTranslationSigma²,
/// kMinRotationSigma²), so no loop becomes rigid. Translation first.
Vector6d floorVariances();
/// Sets closure.covariance and its symmetrised inverse, closure.information.
void setLoopCovariance(LoopClosure& closure, const Matrix6d& covariance);

/// Runs hazmap::registerClouds(query_cloud → match_cloud) from candidate.initial_guess, then
/// evaluateRegistration. Clouds are in their keyframes' sensor frames.
VerificationResult verifyCandidate(const LoopCandidate& candidate, const LabeledCloud& query_cloud,
                                   const LabeledCloud& match_cloud, const ClassTable& classes,
                                   const VerificationConfig& config = {});

/// Same, against a prepared target (the match keyframe's submap), so that one target serves
/// several candidates.
VerificationResult verifyCandidate(const LoopCandidate& candidate, const LabeledCloud& query_cloud,
                                   const RegistrationTarget& match_target, const ClassTable& classes,
                                   const VerificationConfig& config = {});

void validate(const VerificationConfig& config);

}  // namespace hazmap
