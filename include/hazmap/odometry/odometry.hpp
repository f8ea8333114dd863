#pragma once
// LiDAR odometry on top of property-aware ICP.
//  - FrameToFrame: the paper's set-up — each scan is registered to the previous one, the initial
//    guess being the wheel-odometry increment.
//  - FrameToMap: each scan is registered to a bounded local voxel map that keeps classes.
// Without wheel odometry the guess is the last estimated increment (constant velocity). When ICP
// from the guess fails its checks (too few correspondences, low fitness, a correction far from
// the guess), fits poorly, lands suspiciously far from the guess, or there is no motion prior,
// a guess-free global registration against the same target is tried (issue 19); its answer is
// verified by the same ICP and checks and used only when it passes and is not ambiguous
// (status `relocalised`). A frame with no verified answer falls back to the guessed increment
// (status `fallback`, flagged), recording why; along degenerate directions the guess is kept
// while the constrained directions come from ICP.
#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/odometry/frame_history.hpp"
#include "hazmap/odometry/local_map.hpp"
#include "hazmap/odometry/motion_hypotheses_config.hpp"
#include "hazmap/registration/global_registration.hpp"
#include "hazmap/registration/registration.hpp"

namespace hazmap {

enum class OdometryMode { FrameToFrame, FrameToMap };
const char* toString(OdometryMode mode);

/// Recovery when tracking fails (issue 19): a guess-free global registration against the local
/// map or, for a kidnapped robot, the whole map, and lost frames re-estimated once tracking is
/// back. Its internal thresholds (when a frame is suspect, how much better a recovered answer must
/// fit, when two answers are ambiguous) are named constants in src/odometry/odometry_checks.hpp.
struct RecoveryConfig {
  /// On by default: a recovered answer is used only when it fits clearly better than what
  /// tracking would otherwise use, so a frame where ICP from the guess passes is never touched
  /// (relocalise_suspect off) and a failed one changes only for the better.
  bool relocalise = true;  ///< try a guess-free global registration when ICP from the guess fails
  /// Also try it when ICP from the guess passed its checks but is suspect (a poor fit, a large
  /// correction, no motion prior, a weakly constrained horizontal axis). Off by default: a frame
  /// that passes is then never re-examined, so a run where nothing fails costs and gives exactly
  /// what it did before; on for a crawler's worst day (docs/registration.md). It also turns on
  /// flagging weak-axis frames and the label-axis search (LabelAxisConfig).
  bool relocalise_suspect = false;
  /// A recovered increment must be plausible for the platform: at most this far (m) and this
  /// much turned (rad) since the previous frame (a crawler's 2 m slip plus its frame; a car at
  /// 10 Hz with frames dropped).
  double max_translation = 4.0;
  double max_rotation = 1.6;
  /// Whole-map re-localisation (a kidnapped robot): after whole_map_after consecutive fallback
  /// frames, the scan is registered globally against the keyframes (verified frames kept every
  /// keyframe_distance / keyframe_rotation, placed at their current poses, which reanchor() moves
  /// with the pose graph), with no plausibility bound on the motion; verified by the tracking ICP,
  /// confirmed by the next frame, an ambiguous answer refused. Used: status relocalised,
  /// GlobalAttempt::whole_map, and the local map is rebuilt from the keyframes. Needs relocalise.
  bool whole_map = true;
  int whole_map_after = 3;          ///< consecutive fallback frames before the whole map is tried
  double keyframe_distance = 2.0;   ///< m; a verified frame this far from the last keyframe is one
  double keyframe_rotation = 0.5;   ///< rad; …or turned this much
  /// The newest this many keyframes' scans stay in memory; older ones wait on disk (a temporary
  /// folder, every channel bit for bit) until the whole map is built or the local map rebuilt
  /// from them, so a long mission's memory does not grow with its keyframes (one every 2 m).
  /// Not a key: 64 scans are a few tens of MB, and the results do not depend on it (tests lower it).
  std::size_t resident_keyframes = 64;
  /// Frame to map: a fallback frame's scan (its pose an unverified guess) waits outside the local
  /// map, so a lost frame cannot poison the map the next frames track against. Once a later frame
  /// is verified, the waiting frames are re-registered against the recovered map, each from its
  /// pose interpolated between the last frame before the gap and the verified one; an answer that
  /// passes the tracking checks replaces the frame's pose (status relocalised) and its scan enters
  /// the map; otherwise the interpolated pose is kept, flagged (fallback), and the scan stays out.
  /// frames() holds the final values; addFrame()'s returned frame is the one at that time.
  /// naraha worst day: docs/registration.md.
  bool reestimate_lost_frames = true;
  /// At most this many lost frames wait; when more are lost in a row the oldest enters the map at
  /// its guessed pose (held out for longer, the corridor without odometry starved its map).
  int lost_frames_max = 3;
};

/// With relocalise_suspect and property ICP: along a horizontal axis the geometry cannot observe
/// (a corridor), the scan's labelled points decide. They are slid ±range along the axis and scored
/// against the target's labelled points with the paper's rule (same class within its search
/// radius, another class only with the penalty α); the best position is used when it is well
/// supported and unambiguous, otherwise the frame is flagged. The heat panels and puddles of a
/// corridor: docs/registration.md. Its thresholds are named constants in
/// src/odometry/odometry_checks.hpp.
struct LabelAxisConfig {
  bool search = true;
  double range = 2.5;  ///< m either way
};

/// Tracking (Fig. 1: prepare → guess → register → judge → integrate); recovery and the label-axis
/// search have their own sections.
struct OdometryConfig {
  OdometryMode mode = OdometryMode::FrameToMap;
  /// ICP settings (use_classes = property ICP or plain ICP); the same defaults as registerClouds'.
  RegistrationConfig registration;
  // --- preprocessing ---
  double min_range = 1.0;      ///< m; drops the robot's own body
  double max_range = 100.0;    ///< m
  double voxel_size = 0.5;     ///< m; the scan as it enters the map / the next frame's target
  double source_voxel_size = 0.0;  ///< m; the scan registered (0 = voxel_size); coarser = faster
  // --- local map (FrameToMap) ---
  LocalMapConfig map;
  // --- failure detection ---
  double min_fitness = 0.3;               ///< fraction of source points with a correspondence
  double max_correction_translation = 1.0;  ///< m; farther from the guess = diverged
  double max_correction_rotation = 0.2;     ///< rad
  /// Covariance given to a fallback increment (and along degenerate directions).
  double fallback_sigma_translation = 0.1;  ///< m
  double fallback_sigma_rotation = 0.02;    ///< rad
  RecoveryConfig recovery;
  GlobalRegistrationConfig global;  ///< recovery's global registration (its use_classes follows registration's)
  LabelAxisConfig label_axis;
  /// The guess after a sudden turn: motion hypotheses scored before ICP (issue 35).
  MotionHypothesisConfig motion_hypotheses;

  /// The defaults above (max correspondence 1 m, scan voxel 0.5 m, map voxel 1 m), set for the
  /// simulated 10 Hz VLP-16 of the paper's experiment.
  static OdometryConfig defaults();
  void validate() const;
};

/// Field tables (keys, ranges, docs; core/config_fields.hpp, docs/configuration.md).
const ConfigFields<OdometryConfig>& configFields(ConfigTag<OdometryConfig>);
const ConfigFields<LocalMapConfig>& configFields(ConfigTag<LocalMapConfig>);
const ConfigFields<RecoveryConfig>& configFields(ConfigTag<RecoveryConfig>);
const ConfigFields<LabelAxisConfig>& configFields(ConfigTag<LabelAxisConfig>);

/// YAML: the keys of the field table, at top level or under `odometry:`; `map:` and
/// `registration:` are nested sections. Unknown keys are errors naming the closest valid key.
OdometryConfig odometryConfigFromYaml(const std::string& yaml, const std::string& where,
                                      const OdometryConfig& base = OdometryConfig::defaults());
OdometryConfig loadOdometryConfig(const std::string& path,
                                  const OdometryConfig& base = OdometryConfig::defaults());

/// How many frames back a verified frame's re-estimation of the lost frames before it rewrites
/// (recovery.lost_frames_max + 2: the lost frames, the one before them and the verified one).
inline std::size_t reestimationReach(const RecoveryConfig& recovery) {
  return static_cast<std::size_t>(recovery.lost_frames_max) + 2;
}

/// A scan as tracking enters it into the local map (and registers it, unless source_voxel_size
/// is coarser): cropped to [min_range, max_range], downsampled to voxel_size keeping property classes.
LabeledCloud preprocessForTracking(const LabeledCloud& scan, const OdometryConfig& config, const ClassTable& classes);

/// A frame's increment rotation when its registration verified it (tracked), else nullopt: what
/// the gyro's online bias is estimated against (preprocess/imu_motion.hpp).
std::optional<Eigen::Matrix3d> verifiedRotation(const OdometryFrame& f);

class Odometry {
 public:
  Odometry(const ClassTable& classes, const OdometryConfig& config = OdometryConfig::defaults(),
           const Eigen::Isometry3d& initial_pose = Eigen::Isometry3d::Identity());
  ~Odometry();

  /// Processes the next scan (sensor frame). `wheel_increment` = previous ← current from wheel
  /// odometry, if available. Throws hazmap::Error for a class missing from the table (when
  /// classes are used) or a non-finite wheel increment; an empty scan falls back.
  /// `imu_rotation`: previous ← current rotation the gyro measured; it replaces the guess's
  /// rotation (constant velocity's, or the wheels' turn where it differs by more than 2°), the
  /// translation stays theirs.
  const OdometryFrame& addFrame(const LabeledCloud& scan,
                                const std::optional<Eigen::Isometry3d>& wheel_increment = std::nullopt,
                                double stamp = -1.0,
                                const std::optional<Eigen::Matrix3d>& imu_rotation = std::nullopt);

  /// The frames kept in full: every frame, unless keepNewestFrames() was called (then the newest
  /// few, from history().firstKept() on).
  const std::vector<OdometryFrame>& frames() const { return frames_.kept(); }
  /// Every frame's stamp, status and pose; the newest (or all) in full.
  const FrameHistory& history() const { return frames_; }
  /// A long mission's bounded memory (issue 33): from now on only the newest `n` frames are kept
  /// in full (at least reestimationReach(): what re-estimating lost frames reads).
  void keepNewestFrames(std::size_t n);
  /// Whole-map keyframes kept so far, and those of them whose scans are in memory
  /// (RecoveryConfig::resident_keyframes; the others are on disk).
  std::size_t keyframes() const;
  std::size_t residentKeyframes() const;
  Trajectory trajectory() const;
  const LocalMap& localMap() const { return map_; }
  /// Frame to map: tracking continues on a corrected trajectory (issue 14: the map follows the
  /// pose graph). `poses[i]` = the new world ← sensor pose of frame i, one per frame so far; every
  /// local-map point moves with its frame's correction and the frames take the new poses, so the
  /// next frame's guess starts from the corrected pose (odometry_reanchor.cpp). Frame to frame it
  /// changes nothing (registration is relative to the previous scan).
  void reanchor(const std::vector<Eigen::Isometry3d>& poses);
  const OdometryConfig& config() const { return config_; }

 private:
  /// Steps 2–4 of a frame after the first (addFrame): guess → register → judge → place.
  struct Attempt;
  struct Judgement;
  Attempt guess(OdometryFrame& f, const std::optional<Eigen::Isometry3d>& wheel_increment,
                const std::optional<Eigen::Matrix3d>& imu_rotation, std::optional<RegistrationTarget>& map_target) const;
  /// Motion hypotheses (motion_hypotheses.cpp): may replace the guess by a better-fitting start.
  void seedFromHypotheses(OdometryFrame& f, Attempt& a, const LabeledCloud& source);
  Judgement judge(OdometryFrame& f, const LabeledCloud& source, const Attempt& a,
                  std::optional<RegistrationTarget>& map_target, RegistrationResult& r);
  void place(OdometryFrame& f, const Attempt& a, const Judgement& j, RegistrationResult r);
  /// Recovery of a triggered frame (odometry_recover.cpp): ICP from a global registration's
  /// answer and from a few other starts around the motion prior, each verified by the tracking
  /// checks and the plausibility bounds. Returns the best verified answer; `from_guess` (ICP
  /// from the guess) competes when `guess_passed`. Nothing when no answer is verified or two
  /// distinct ones fit alike (ambiguous); f.global.outcome says which. `probes_only` (the only
  /// trigger was a weak axis): ICP from the guess against probes along that axis, nothing else.
  struct Recovery {
    RegistrationResult registration;
    bool from_guess = false;  ///< ICP from the guess won
  };
  std::optional<Recovery> recover(OdometryFrame& f, const LabeledCloud& source,
                                            const RegistrationTarget& target, const Eigen::Isometry3d& W,
                                            const RegistrationResult& from_guess, bool guess_passed,
                                            bool probes_only = false);
  /// The global registration's answer (W space), if it has one that is not ambiguous.
  std::optional<Eigen::Isometry3d> globalStart(OdometryFrame& f, const LabeledCloud& source,
                                               const RegistrationTarget& target, const Eigen::Isometry3d& W);
  /// Step 5: the scan (`frame`, preprocessed) enters the local map or becomes the next target.
  void remember(OdometryFrame& f, const LabeledCloud& frame);
  /// Part of judge(): recovery when a trigger fires; returns the failure left (empty = use
  /// `r`), `relocalised` when a recovered answer replaced r.
  std::string checkAndRecover(OdometryFrame& f, const LabeledCloud& source, const RegistrationTarget* target,
                              const Eigen::Isometry3d& W, const Eigen::Isometry3d& reg_guess, bool has_prior,
                              RegistrationResult& r, bool& relocalised);
  /// With labelsDecideAxes: `r` weakly constrained along a horizontal axis (below `ratio`) is
  /// placed along it by the scan's labels (odometry_labels.cpp); false when not weak or undecided.
  bool placeAlongWeakAxis(const LabeledCloud& source, const RegistrationTarget& target, RegistrationResult& r,
                          double ratio);
  /// labelsDecideAxes (odometry_labels.cpp): this scan's labelled points and the label map of the
  /// verified frames, for the frame about to be tracked.
  void prepareLabels(const LabeledCloud& scan);
  /// Whole-map re-localisation (odometry_whole_map.cpp): the scan against the keyframes; the
  /// verified answer (world ← scan) or nothing, f.global says why.
  std::optional<RegistrationResult> relocaliseInWholeMap(OdometryFrame& f, const LabeledCloud& source,
                                                         const Eigen::Isometry3d& world_guess);
  /// Keyframes (odometry_whole_map.cpp): a verified frame far enough from the last one becomes
  /// one; after a whole-map re-localisation the local map is rebuilt from them.
  void keepKeyframe(const OdometryFrame& f, const LabeledCloud& frame);
  /// the whole-map confirmation: whether the previous frame's whole-map answer agrees with `answer`.
  bool confirmed(const Eigen::Isometry3d& answer, std::size_t frame);
  void rebuildLocalMapFromKeyframes(const Eigen::Isometry3d& pose);
  /// reestimate_lost_frames (odometry_lost.cpp): `f` (not yet in frames_) was verified; the
  /// waiting fallback frames get their poses re-estimated against the map plus `f_world` (f's scan
  /// in the world). Returns the scans (world) of the frames re-registered, to enter the map with f's.
  LabeledCloud reestimateLostFrames(OdometryFrame& f, const LabeledCloud& f_world);
  /// A lost frame's re-registered answer `r` along its weak axis (odometry_lost.cpp): why it
  /// cannot be used, empty when it can (the labels may have moved it; `note` says how).
  std::string placeLostFrameAlongAxis(const LabeledCloud& scan, const LabeledCloud& labels,
                                      const RegistrationTarget& target, RegistrationResult& r, Vector6d& correction,
                                      std::string& note, bool& precise);

  struct Impl;
  ClassTable classes_;
  OdometryConfig config_;
  Eigen::Isometry3d initial_pose_;
  LocalMap map_;
  FrameHistory frames_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hazmap
