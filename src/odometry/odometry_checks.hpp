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
#include "hazmap/odometry/odometry.hpp"
#include "odometry/motion_hypotheses.hpp"

namespace hazmap {

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
    LabeledCloud scan;      ///< preprocessed, sensor frame
  };
  std::vector<Keyframe> keyframes;
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
  /// whole_map_confirm: the last frame's verified whole-map answer (world ← scan), awaiting the next.
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

/// Whether the inlier RMSE is above relocalise_max_rmse_ratio × that of tracked frames
/// (`typical_rmse`, 0 = not known yet): a right answer fits about as well as they do.
inline bool fitsWorseThanTracked(const RegistrationResult& r, double typical_rmse, const OdometryConfig& config) {
  return typical_rmse > 0.0 && r.inlier_rmse > config.relocalise_max_rmse_ratio * typical_rmse;
}

/// Whether `motion` is one the platform can make between two frames (relocalise_max_translation,
/// relocalise_max_rotation).
inline bool plausibleMotion(const Eigen::Isometry3d& motion, const OdometryConfig& config) {
  return translationNorm(motion) <= config.relocalise_max_translation &&
         rotationAngle(motion) <= config.relocalise_max_rotation;
}

/// The odometry's global registration settings: its use_classes follows the registration's.
inline GlobalRegistrationConfig globalConfigOf(const OdometryConfig& config) {
  GlobalRegistrationConfig gc = config.global;
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

/// Share of the source points on a target surface at `pose` (W ← source): nearest target point
/// within the correspondence gate, at most `inlier_distance` from it along its normal.
double surfaceFit(const LabeledCloud& source, const RegistrationTarget& target, const Eigen::Isometry3d& pose,
                  double inlier_distance);

/// Where the scan's labelled points say the pose lies along `axis` (odometry_labels.cpp): the
/// offset (m) from `pose` whose label score is clearly best, or undecided (no labelled point in
/// view, too little support, or another position scoring nearly as well).
struct LabelPlacement {
  bool decided = false;
  bool precise = false;  ///< the two halves of the labelled points agree (label_axis_consistency)
  double offset = 0.0;   ///< m along the axis from the pose
  double score = 0.0;    ///< label score there
  double second = 0.0;   ///< the next peak's score (at least label_axis_gate away)
  double spread = 0.0;   ///< m between the halves' answers
  std::size_t labelled = 0;  ///< labelled scan points
  std::size_t support = 0;   ///< of them, with a labelled partner at the offset
  std::string why;           ///< why undecided
};
LabelPlacement placeAlongAxisByLabels(const LabelView& view, const ClassTable& classes, const Eigen::Isometry3d& pose,
                                      const Eigen::Vector3d& axis, const OdometryConfig& config);
/// A scan's labelled points for the label search: property classes within the crop range, lone
/// returns (fewer than two of their class within 2 cm per metre of range) dropped, at label_axis_voxel.
LabeledCloud labelledPointsOf(const LabeledCloud& scan, const OdometryConfig& config, const ClassTable& classes);
/// Labelled points of frames placed at their poses, downsampled at label_axis_voxel.
LabeledCloud labelMapOf(const std::vector<std::pair<Eigen::Isometry3d, const LabeledCloud*>>& frames,
                        const OdometryConfig& config, const ClassTable& classes);
/// "labels placed it +0.40 m along the weak axis (…)" or why undecided.
std::string describe(const LabelPlacement& placement);
/// `pose` moved `offset` along `axis` (registration space).
Eigen::Isometry3d shiftedAlong(const Eigen::Isometry3d& pose, const Eigen::Vector3d& axis, double offset);
/// Another position along the answer's weakest horizontal axis that fits (surface fit) as well:
/// ICP restarted ±1, ±2 relocalise_axis_step along it. Empty when none; else the ambiguity.
std::string ambiguousAlongWeakestAxis(const LabeledCloud& source, const RegistrationTarget& target,
                                      const ClassTable& classes, const OdometryConfig& config,
                                      const OdometryConfig& seed_config, const RegistrationResult& answer, double fit,
                                      const std::string& answer_name);
/// Moves `r` by the placement along `axis`, with label_axis_sigma² added there to its covariance.
void applyLabelPlacement(RegistrationResult& r, const Eigen::Vector3d& axis, const LabelPlacement& placement,
                         const OdometryConfig& config);
/// An answer the geometry cannot place along a horizontal axis (weaker than flag_weak_axis_ratio,
/// or `doubt`: another position along its weakest axis fits as well): the labels decide
/// (labelsDecideAxes). Placed: the answer moves along the axis (`placed_along`, when given) and
/// `note` says so; else `doubt` (or the labels' reason) stays. Returns whether it may be used.
bool placeByLabels(const LabelView& view, const LabeledCloud& source, const RegistrationTarget& target,
                   const ClassTable& classes, const OdometryConfig& config, RegistrationResult& answer,
                   std::string& doubt, std::string& note, bool& precise, Eigen::Vector3d* placed_along);
/// Whether a label placement may move `r` (in place; false = leave it, the caller flags it): a
/// move within label_axis_confirm confirms ICP's answer and leaves it where it is (ICP is the
/// finer of the two where it has anything to go by: naraha's weak-axis frames); a larger one only
/// when the scan still fits the target as well there (surface fit within relocalise_ambiguity: a
/// corridor fits anywhere along it, a room does not).
bool applyPlacementIfGeometryAllows(const LabeledCloud& source, const RegistrationTarget& target, RegistrationResult& r,
                                    const Eigen::Vector3d& axis, const LabelPlacement& placement,
                                    const OdometryConfig& config);
/// An answer the geometry placed (not weak) that its labels, decided, put more than
/// relocalise_distinct_translation elsewhere along its weakest horizontal axis: why it is refused
/// (empty when they agree, cannot tell, or their position fits the geometry worse). A recovery
/// answer slid a metre along a corridor whose walls fitted either way.
std::string labelsContradict(const LabelView& view, const LabeledCloud& source, const RegistrationTarget& target,
                             const ClassTable& classes, const OdometryConfig& config, const RegistrationResult& answer);
/// The checks of ICP from a recovery start (a seed): it may travel up to relocalise_start_correction.
inline OdometryConfig seedConfigOf(const OdometryConfig& config) {
  OdometryConfig seed = config;
  seed.max_correction_translation = std::max(config.max_correction_translation, config.relocalise_start_correction);
  seed.max_correction_rotation = std::max(config.max_correction_rotation, config.relocalise_start_correction_rotation);
  return seed;
}
/// Whether labels may decide along weak axes: relocalise_suspect, label_axis_search, property ICP,
/// frame to map.
inline bool labelsDecideAxes(const OdometryConfig& config) {
  return config.relocalise_suspect && config.label_axis_search && config.registration.use_classes &&
         config.mode == OdometryMode::FrameToMap;
}

}  // namespace hazmap
