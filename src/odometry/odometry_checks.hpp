#pragma once
// Failure detection of the odometry, shared by tracking (odometry.cpp) and the recovery of
// frames where tracking failed (odometry_recover.cpp).
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/registration/global_registration.hpp"
#include "hazmap/registration/registration_target.hpp"

#include "hazmap/core/se3.hpp"
#include "hazmap/io/keyframe_spill.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "odometry/motion_hypotheses.hpp"

namespace hazmap {

// Internal thresholds of failure detection and recovery (issue 37: not keys; every key is a
// default path or a user's choice). Measured on naraha, the corridor and the tanks' worst days
// (docs/registration.md); their old keys name this file (src/core/retired_keys.cpp).

// --- when ICP from the guess, though it passed, is suspect (with relocalise_suspect) ---
/// A right answer fits its map at 0.7-0.95 here; below 0.5 the scan matched only in part.
constexpr double kSuspectFitness = 0.5;
/// A crawler's guess is off by centimetres; a correction of 0.5 m / 0.1 rad means a slip or a wrong basin.
constexpr double kSuspectCorrectionTranslation = 0.5;
constexpr double kSuspectCorrectionRotation = 0.1;
/// Weakest horizontal Hessian eigenvalue (rotation marginalised) below this × the strongest: a
/// corridor whose walls say nothing along it ("no motion" fits as well as the true step).
constexpr double kSuspectWeakAxisRatio = 0.15;
/// The weak-axis ratio that flags a frame recovery did not replace: looser than the suspect one,
/// since flagging keeps ICP's answer (the corridor's frames sit at 0.15-0.25; at 0.15 some stayed
/// `tracked` 1 m wrong).
constexpr double kFlagWeakAxisRatio = 0.25;
/// The same check on the scan's own surfaces (scanWeakHorizontalAxis), for a frame ICP's Hessian
/// finds constrained: the scan's normals are sparser than the map's, so its ratio sits lower
/// (naraha's corridor 0.15-0.25 where ICP is right; 0.25 flagged right frames there and moved
/// corridor seed 3's; 0.15, asked without wheel odometry only: corridor seed 1 without wheels, with
/// the gyro, 20 → 0 frames silently wrong, seeds 2-3 unchanged; docs/formats.md, the IMU).
constexpr double kScanWeakAxisRatio = 0.15;
/// Normals over 2 m and 30 neighbours for it, so that a plane spans several rings (tracking's 1 m
/// and 10 neighbours in a local map can fit a lone ring's line in any direction).
constexpr int kScanSurfaceNeighbors = 30;
constexpr double kScanSurfaceRadius = 2.0;
/// A frame after a flagged one whose answer lies farther than this (m) from the guess along that
/// frame's weakest axis is flagged too: the previous pose's error or a slip moved it (corridor
/// worst day: 0.49 m off in its increment).
constexpr double kFlagCorrectionAfterFlagged = 0.15;
/// With wheel odometry: an answer farther than this (m) from the wheels' guess along the scan's
/// own weak horizontal axis is flagged. The walls cannot have moved it there, so the map did (a
/// feature integrated where an earlier flagged frame put it) or the wheels slipped: the data
/// cannot tell which (corridor worst day, seed 3: frames 66 and 80 `tracked` 0.22-0.24 m off
/// along the corridor, pulled from wheels that were within 4 cm).
constexpr double kFlagWheelDisagreement = 0.15;

// --- recovery's starts and how its answers are scored ---
/// m; recovery also starts ICP at ±1 and ±2 steps along a weak axis (a corridor's repeated bays).
constexpr double kAxisProbeStep = 1.0;
/// A weak-axis probe's answer must fit this much better than the other answers: a probe that
/// lands in a neighbouring bay fits almost as well.
constexpr double kProbeGain = 0.2;
/// ICP from a start other than the guess may end this far from it (m / rad): a start is a seed, not a prior.
constexpr double kStartCorrectionTranslation = 2.0;
constexpr double kStartCorrectionRotation = 0.5;
/// A recovered answer replaces what tracking would use only when its surface fit is this much
/// better: a frame changes only for the better, never on noise.
constexpr double kRecoveryMinGain = 0.05;
/// m; a source point this close to a target surface (along its normal) fits: about the scan's noise.
constexpr double kSurfaceInlierDistance = 0.1;
/// Two verified answers this far apart (m / rad) whose surface fits differ by less than
/// kRecoveryAmbiguity make the frame ambiguous: flagged, not relocalised.
constexpr double kDistinctTranslation = 0.3;
constexpr double kDistinctRotation = 0.05;
constexpr double kRecoveryAmbiguity = 0.03;
/// A wrong pose still finds partners in a dense map but fits them worse: a recovered answer whose
/// inlier RMSE exceeds this × that of tracked frames is rejected.
constexpr double kMaxRmseRatio = 1.5;
/// m; the global registration's target is the local map within this of the previous pose (the
/// VLP-16's useful range, with room for a slip).
constexpr double kRecoveryMapRadius = 40.0;
/// A whole-map answer must put this share of the source points on a keyframe surface.
constexpr double kWholeMapMinFit = 0.5;

// --- the label-axis search (LabelAxisConfig) ---
/// m; a labelled pair within this (cost, with the mismatch penalty) scores.
constexpr double kLabelAxisGate = 0.5;
/// Label score the best position needs: about three well-matched labelled points.
constexpr double kLabelAxisMinSupport = 3.0;
/// A position kLabelAxisGate or more from the best scoring this × as much leaves it undecided.
constexpr double kLabelAxisAmbiguity = 0.85;
/// m; standard deviation added along the axis when labels placed the frame (a patch's extent).
constexpr double kLabelAxisSigma = 0.05;
/// m; the labelled points' resolution for the search (finer than a patch).
constexpr double kLabelAxisVoxel = 0.1;
/// m; labels placing the frame within this of ICP's answer confirm it (ICP's answer is kept: where
/// the geometry has anything to go by it is the finer of the two; naraha's weak-axis frames).
constexpr double kLabelAxisConfirm = 0.1;
/// m; unlabelled returns this close to labelled ones take part (a mismatch costs α): they show
/// where a panel ends, so a partial view cannot slide along it.
constexpr double kLabelAxisContext = 0.5;
/// m; the two halves of the labelled points must place the frame this close, or it stays flagged
/// (far patches at a grazing angle).
constexpr double kLabelAxisConsistency = 0.05;

/// The labelled points the label search compares: this scan's (sensor frame) and the map's
/// (registration space). Either may be missing (nothing to compare).
struct LabelView {
  const LabeledCloud* scan = nullptr;
  const LabeledCloud* map = nullptr;
};

/// The keyframes assembled into one cloud, prepared for global registration and ICP.
struct WholeMap;

struct Odometry::Impl {
  std::unique_ptr<RegistrationTarget> previous;  ///< FrameToFrame: the last non-empty scan
  Eigen::Isometry3d previous_pose = Eigen::Isometry3d::Identity();  ///< its pose (world ← scan)
  Eigen::Isometry3d velocity = Eigen::Isometry3d::Identity();  ///< last increment
  bool has_velocity = false;
  bool velocity_verified = false;  ///< the last increment came from a verified registration
  /// Running mean of the inlier RMSE of tracked frames: how well a right answer fits here.
  double typical_rmse = 0.0;
  // --- whole-map re-localisation (odometry_whole_map.cpp) ---
  struct Keyframe {
    std::size_t frame = 0;  ///< index into frames_ (its pose is the current estimate)
    LabeledCloud scan;      ///< preprocessed, sensor frame; empty once on disk
    bool on_disk = false;   ///< beyond RecoveryConfig::resident_keyframes: in keyframe_spill
  };
  std::vector<Keyframe> keyframes;
  std::optional<KeyframeSpill> keyframe_spill;  ///< created with the first keyframe it takes
  /// Keyframe k's scan: in memory, or read back from disk into `holder`.
  const LabeledCloud& keyframeScan(std::size_t k, const ClassTable& classes, LabeledCloud& holder) const {
    if (!keyframes[k].on_disk) return keyframes[k].scan;
    holder = keyframe_spill->load(keyframes[k].frame, classes);
    return holder;
  }
  std::size_t fallback_streak = 0;
  /// Frame to map (reestimate_lost_frames): the fallback frames since the last verified one, their
  /// preprocessed scans (sensor frame) waiting outside the local map.
  struct LostFrame {
    std::size_t frame = 0;
    LabeledCloud scan;
    LabeledCloud labels;  ///< its labelled points (labelsDecideAxes)
  };
  std::vector<LostFrame> lost;
  /// The whole map as last prepared (rebuilt when keyframes were added or re-anchored since).
  std::shared_ptr<const WholeMap> whole_map;
  /// the whole-map confirmation: the last frame's verified whole-map answer (world ← scan), awaiting the next.
  std::optional<Eigen::Isometry3d> whole_map_candidate;
  std::size_t whole_map_candidate_frame = 0;
  std::size_t whole_map_keyframes = 0, whole_map_version = 0, reanchors = 0;
  /// The frame being tracked was placed along a weak axis by its labels (odometry_labels.cpp):
  /// how, for its reason; empty = not (then a weak axis flags it).
  std::string label_note;
  std::string label_doubt;  ///< why the labels did not place it (for a flagged frame's reason)
  bool label_precise = false;  ///< the labels placed it precisely (else it stays flagged)
  /// labelsDecideAxes: every frame's labelled points (labelledPointsOf, sensor frame); the label
  /// map is built from those of verified frames at their current poses when a frame starts.
  std::vector<std::pair<std::size_t, LabeledCloud>> frame_labels;
  LabeledCloud scan_labels;  ///< the current frame's
  LabeledCloud label_map;    ///< world
  LabelView labelView() const { return {&scan_labels, &label_map}; }
  MotionHypotheses hypotheses;  ///< motion_hypotheses.cpp: the running score of the guesses
};

/// Why ICP's answer cannot be used (empty when it can): did not converge (stopping at the
/// iteration limit is not a failure), fitness below min_fitness, or a correction of the start
/// larger than max_correction_*.
std::string registrationFailure(const RegistrationResult& r, const Eigen::Isometry3d& start,
                                const OdometryConfig& config);

using Clock = std::chrono::steady_clock;
inline double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

/// Whether the inlier RMSE is above kMaxRmseRatio × that of tracked frames
/// (`typical_rmse`, 0 = not known yet): a right answer fits about as well as they do.
inline bool fitsWorseThanTracked(const RegistrationResult& r, double typical_rmse) {
  return typical_rmse > 0.0 && r.inlier_rmse > kMaxRmseRatio * typical_rmse;
}

/// Whether `motion` is one the platform can make between two frames (recovery.max_translation,
/// recovery.max_rotation).
inline bool plausibleMotion(const Eigen::Isometry3d& motion, const OdometryConfig& config) {
  return translationNorm(motion) <= config.recovery.max_translation &&
         rotationAngle(motion) <= config.recovery.max_rotation;
}

/// Nearest-target searches an ICP made (OdometryFrame::searches): each pass of each stage
/// searches every source point it uses.
inline std::size_t icpSearches(const RegistrationResult& r, const RegistrationConfig& c) {
  return static_cast<std::size_t>(r.iterations) * r.stats.source_points +
         static_cast<std::size_t>(r.coarse_iterations) * c.coarse_source_points;
}

/// The odometry's global registration settings: its use_classes follows the registration's.
inline GlobalRegistrationConfig globalConfigOf(const OdometryConfig& config) {
  GlobalRegistrationConfig gc = config.global;
  gc.tracking_registration = config.registration;  // the refinement overrides tracking's ICP
  gc.use_classes = gc.use_classes && config.registration.use_classes;
  return gc;
}

/// The covariance of a fallback increment (fallback_sigma_*).
Matrix6d fallbackCovariance(const OdometryConfig& config);

/// How far ICP moved the sensor from `start` (start⁻¹ · answer: translation in the sensor frame).
Vector6d correctionOf(const RegistrationResult& r, const Eigen::Isometry3d& start);

/// Whether every degenerate direction is vertical (height, roll, pitch): a ground robot's
/// recovery seeds differ in yaw and horizontal position, so ICP from a seed that slides only
/// vertically still says where the robot is (naraha frames 50-55: the floor out of view).
bool onlyVerticalDegeneracy(const std::vector<Vector6d>& directions);

/// The registration's weakest horizontal translation axis (unit, registration space) when its
/// Hessian eigenvalue, rotation marginalised, is below `ratio` × the strongest; else nothing.
std::optional<Eigen::Vector3d> weakHorizontalAxis(const RegistrationResult& r, double ratio);
/// The same for a point-to-plane Hessian (translation first, then rotation).
std::optional<Eigen::Vector3d> weakHorizontalAxis(const Matrix6d& hessian, double ratio);

/// Share of the source points on a target surface at `pose` (W ← source): nearest target point
/// within the correspondence gate, at most `inlier_distance` from it along its normal.
double surfaceFit(const LabeledCloud& source, const RegistrationTarget& target, const Eigen::Isometry3d& pose,
                  double inlier_distance);

/// Where the scan's labelled points say the pose lies along `axis` (odometry_labels.cpp): the
/// offset (m) from `pose` whose label score is clearly best, or undecided (no labelled point in
/// view, too little support, or another position scoring nearly as well).
struct LabelPlacement {
  bool decided = false;
  bool precise = false;  ///< the two halves of the labelled points agree (kLabelAxisConsistency)
  double offset = 0.0;   ///< m along the axis from the pose
  double score = 0.0;    ///< label score there
  double second = 0.0;   ///< the next peak's score (at least kLabelAxisGate away)
  double spread = 0.0;   ///< m between the halves' answers
  std::size_t labelled = 0;  ///< labelled scan points
  std::size_t support = 0;   ///< of them, with a labelled partner at the offset
  std::string why;           ///< why undecided
};
LabelPlacement placeAlongAxisByLabels(const LabelView& view, const ClassTable& classes, const Eigen::Isometry3d& pose,
                                      const Eigen::Vector3d& axis, const OdometryConfig& config);
/// A scan's labelled points for the label search: property classes within the crop range, lone
/// returns (fewer than two of their class within 2 cm per metre of range) dropped, at kLabelAxisVoxel.
LabeledCloud labelledPointsOf(const LabeledCloud& scan, const OdometryConfig& config, const ClassTable& classes);
/// Labelled points of frames placed at their poses, downsampled at kLabelAxisVoxel.
LabeledCloud labelMapOf(const std::vector<std::pair<Eigen::Isometry3d, const LabeledCloud*>>& frames,
                        const ClassTable& classes);
/// "labels placed it +0.40 m along the weak axis (…)" or why undecided.
std::string describe(const LabelPlacement& placement);
/// `pose` moved `offset` along `axis` (registration space).
Eigen::Isometry3d shiftedAlong(const Eigen::Isometry3d& pose, const Eigen::Vector3d& axis, double offset);
/// Another position along the answer's weakest horizontal axis that fits (surface fit) as well:
/// ICP restarted ±1, ±2 kAxisProbeStep along it. Empty when none; else the ambiguity.
std::string ambiguousAlongWeakestAxis(const LabeledCloud& source, const RegistrationTarget& target,
                                      const ClassTable& classes, const OdometryConfig& config,
                                      const OdometryConfig& seed_config, const RegistrationResult& answer, double fit,
                                      const std::string& answer_name);
/// Moves `r` by the placement along `axis`, with label_axis_sigma² added there to its covariance.
void applyLabelPlacement(RegistrationResult& r, const Eigen::Vector3d& axis, const LabelPlacement& placement);
/// An answer the geometry cannot place along a horizontal axis (weaker than kFlagWeakAxisRatio,
/// or `doubt`: another position along its weakest axis fits as well): the labels decide
/// (labelsDecideAxes). Placed: the answer moves along the axis (`placed_along`, when given) and
/// `note` says so; else `doubt` (or the labels' reason) stays. Returns whether it may be used.
bool placeByLabels(const LabelView& view, const LabeledCloud& source, const RegistrationTarget& target,
                   const ClassTable& classes, const OdometryConfig& config, RegistrationResult& answer,
                   std::string& doubt, std::string& note, bool& precise, Eigen::Vector3d* placed_along);
/// Whether a label placement may move `r` (in place; false = leave it, the caller flags it): a
/// move within kLabelAxisConfirm confirms ICP's answer and leaves it where it is (ICP is the
/// finer of the two where it has anything to go by: naraha's weak-axis frames); a larger one only
/// when the scan still fits the target as well there (surface fit within kRecoveryAmbiguity: a
/// corridor fits anywhere along it, a room does not).
bool applyPlacementIfGeometryAllows(const LabeledCloud& source, const RegistrationTarget& target, RegistrationResult& r,
                                    const Eigen::Vector3d& axis, const LabelPlacement& placement);
/// An answer the geometry placed (not weak) that its labels, decided, put more than
/// kDistinctTranslation elsewhere along its weakest horizontal axis: why it is refused
/// (empty when they agree, cannot tell, or their position fits the geometry worse). A recovery
/// answer slid a metre along a corridor whose walls fitted either way.
std::string labelsContradict(const LabelView& view, const LabeledCloud& source, const RegistrationTarget& target,
                             const ClassTable& classes, const OdometryConfig& config, const RegistrationResult& answer);
/// The checks of ICP from a recovery start (a seed): it may travel up to kStartCorrectionTranslation.
inline OdometryConfig seedConfigOf(const OdometryConfig& config) {
  OdometryConfig seed = config;
  seed.max_correction_translation = std::max(config.max_correction_translation, kStartCorrectionTranslation);
  seed.max_correction_rotation = std::max(config.max_correction_rotation, kStartCorrectionRotation);
  return seed;
}
/// Whether labels may decide along weak axes: relocalise_suspect, label_axis.search, property ICP,
/// frame to map.
inline bool labelsDecideAxes(const OdometryConfig& config) {
  return config.recovery.relocalise_suspect && config.label_axis.search && config.registration.use_classes &&
         config.mode == OdometryMode::FrameToMap;
}

}  // namespace hazmap
