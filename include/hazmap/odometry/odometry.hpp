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
#include "hazmap/odometry/local_map.hpp"
#include "hazmap/odometry/motion_hypotheses_config.hpp"
#include "hazmap/registration/global_registration.hpp"
#include "hazmap/registration/registration.hpp"

namespace hazmap {

enum class OdometryMode { FrameToFrame, FrameToMap };
const char* toString(OdometryMode mode);

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
  bool keep_guess_along_degenerate = true;  ///< replace ICP's degenerate directions by the guess
  /// Covariance given to a fallback increment (and along degenerate directions).
  double fallback_sigma_translation = 0.1;  ///< m
  double fallback_sigma_rotation = 0.02;    ///< rad
  // --- global registration when tracking fails (issue 19) ---
  /// On by default: a recovered answer is used only when it fits clearly better than what
  /// tracking would otherwise use (relocalise_min_gain), so a frame where ICP from the guess
  /// passes is never touched (relocalise_suspect off) and a failed one changes only for the better.
  bool relocalise = true;  ///< try a guess-free global registration when a trigger below fires
  /// Also try it when ICP from the guess passed its checks but is suspect (below, or no motion
  /// prior: no wheel odometry and no verified last increment). Off by
  /// default: a frame that passes is then never re-examined, so a run where nothing fails costs
  /// and gives exactly what it did before; on for a crawler's worst day (docs/registration.md).
  bool relocalise_suspect = false;
  /// Suspect: ICP from the guess fits worse than this (fitness), or its inlier RMSE is above
  /// relocalise_max_rmse_ratio × that of tracked frames…
  double suspect_fitness = 0.5;
  /// …or corrected the guess by more than this (m / rad), or there was no motion prior…
  double suspect_correction_translation = 0.5;
  double suspect_correction_rotation = 0.1;
  /// …or is weakly constrained along a horizontal axis: the smallest eigenvalue of the ICP
  /// Hessian's translation block (rotation marginalised) below this × the largest (a corridor
  /// whose walls say nothing along it: "no motion" fits as well as the true step). Recovery then
  /// also starts ICP at ±relocalise_axis_step and ±2×relocalise_axis_step along that axis; two
  /// answers that fit alike make the frame ambiguous (flagged) instead of silently wrong.
  double suspect_weak_axis_ratio = 0.15;
  double relocalise_axis_step = 1.0;  ///< m
  /// A probe's answer is used only when it fits better than the best other answer (ICP from the
  /// guess with its relocalise_min_gain head start) by this much (1 = probes never used).
  double relocalise_probe_gain = 0.2;
  /// ICP from a recovery start other than the guess may end this far from that start (m / rad;
  /// the tracking limits max_correction_* apply when larger): a start is a seed, not a prior.
  double relocalise_start_correction = 2.0;
  double relocalise_start_correction_rotation = 0.5;
  /// A recovered answer replaces ICP from the guess (when that passed) or the guess itself (when
  /// it failed) only when it fits better by at least this much: share of source points within
  /// relocalise_inlier_distance of a target surface.
  double relocalise_min_gain = 0.05;
  /// m; a source point this close to a target surface (along its normal) fits (scores recovery).
  double relocalise_inlier_distance = 0.1;
  /// A recovered increment must be plausible for the platform: at most this far (m) and this
  /// much turned (rad) since the previous frame (a crawler's 2 m slip plus its frame; a car at
  /// 10 Hz with frames dropped).
  double relocalise_max_translation = 4.0;
  double relocalise_max_rotation = 1.6;
  /// Two verified answers this far apart (m / rad) whose fitness differs by less than
  /// relocalise_ambiguity (surface fit, as relocalise_min_gain) make the frame ambiguous:
  /// flagged, not relocalised.
  double relocalise_distinct_translation = 0.3;
  double relocalise_distinct_rotation = 0.05;
  double relocalise_ambiguity = 0.03;
  /// A recovered answer whose inlier RMSE exceeds this × the running RMSE of tracked frames is
  /// rejected (a wrong pose still finds partners in a dense map; it fits them worse).
  double relocalise_max_rmse_ratio = 1.5;
  /// The global registration's target: the local map within this radius (m) of the previous pose.
  double relocalise_map_radius = 40.0;
  GlobalRegistrationConfig global;  ///< the global registration (its use_classes follows registration's)
  // --- whole-map re-localisation: a kidnapped robot (issue 19) ---
  /// After whole_map_after consecutive fallback frames, the scan is registered globally against the
  /// whole map: the keyframes (verified frames kept every keyframe_distance / keyframe_rotation,
  /// their scans placed at their current poses, which reanchor() moves with the pose graph), with
  /// no plausibility bound on the motion. The answer is verified by the tracking ICP against the
  /// keyframes, must fit (surface fit) at least whole_map_min_fit and better than the guess by
  /// relocalise_min_gain, and an ambiguous global registration is refused. Used: status
  /// relocalised, GlobalAttempt::whole_map, and the local map is rebuilt from the keyframes (the
  /// scans placed while lost are dropped). Needs relocalise; costs nothing until tracking fails.
  bool whole_map_relocalise = true;
  int whole_map_after = 3;           ///< consecutive fallback frames before the whole map is tried
  double keyframe_distance = 2.0;    ///< m; a verified frame this far from the last keyframe is one
  double keyframe_rotation = 0.5;    ///< rad; …or turned this much
  double whole_map_min_fit = 0.5;    ///< share of source points on a keyframe surface
  /// A whole-map answer is used only when the next frame's whole-map answer agrees with it (within
  /// relocalise_max_translation / relocalise_max_rotation): a single scan can look like another
  /// place (naraha without odometry: 27.8 m / 127 deg off with surface fit 0.71).
  bool whole_map_confirm = true;
  // --- lost frames (frame to map) ---
  /// Frame to map: a fallback frame's scan (its pose an unverified guess) waits outside the local
  /// map, so a lost frame cannot poison the map the next frames track against. Once a later frame
  /// is verified (tracked, degenerate or relocalised against the map without them), the waiting
  /// frames are re-registered against the recovered map, each from its pose interpolated between
  /// the last frame before the gap and the verified one; an answer that passes the tracking checks
  /// (and is horizontally constrained, fits like tracked frames, a plausible motion on both sides)
  /// replaces the frame's pose (status relocalised) and its scan enters the map with the verified
  /// frame's; otherwise the interpolated pose is kept, flagged (fallback), and the scan stays out.
  /// The increments on both sides follow (frames() holds the final values; addFrame()'s returned
  /// frame is the one at that time). After a whole-map re-localisation (a kidnapped robot) the
  /// waiting frames keep their poses, flagged. naraha worst day: docs/registration.md.
  bool reestimate_lost_frames = true;
  /// At most this many lost frames wait; when more are lost in a row the oldest enters the map at
  /// its guessed pose (the map follows the robot through a stretch nothing can verify: held out
  /// for longer, the corridor without odometry starved its map, 1 -> 61 of 99 frames silently wrong).
  int lost_frames_max = 3;
  /// With relocalise_suspect: a frame whose ICP is weakly constrained along a horizontal axis
  /// (suspect_weak_axis_ratio) and that recovery did not replace is flagged (status degenerate,
  /// fallback covariance along the axis) instead of `tracked`: along that axis ICP cannot know the
  /// motion (a corridor).
  bool flag_weak_axis = true;
  /// The weak-axis ratio that flags (as suspect_weak_axis_ratio, which triggers recovery): looser,
  /// since flagging keeps ICP's answer. The corridor's frames sit at 0.15-0.25 and, at 0.15, some
  /// stayed `tracked` 1 m wrong depending on the map's content.
  double flag_weak_axis_ratio = 0.25;
  /// With relocalise_suspect: a frame after a flagged one (degenerate; a fallback when lost frames
  /// are not re-estimated) starts its increment from a pose not known along that frame's weakest
  /// horizontal axis. When its answer lies more than this (m) from the guess along that axis, the
  /// previous pose's error or a slip moved it, which nothing tells apart: flagged, not `tracked`
  /// (corridor worst day: a frame beside a heat panel put right a previous frame 0.4 m off and
  /// was 0.49 m off in its increment; 0 = off).
  double flag_correction_after_flagged = 0.15;
  /// With relocalise_suspect and property ICP: along a horizontal axis the geometry cannot observe
  /// (weaker than flag_weak_axis_ratio, or another position along it fits as well), the scan's
  /// labelled points decide. They are slid ±label_axis_range along the axis and scored against the
  /// target's labelled points with the paper's rule (same class within its search radius, another
  /// class only with the penalty α; a pair within label_axis_gate adds its class weight × (1 −
  /// cost / gate²)); the best position is used when its score is at least label_axis_min_support
  /// and no position label_axis_gate or more away scores label_axis_ambiguity × as much. Otherwise
  /// (no labelled point in view, an even score) the frame is flagged as before. The heat panels and
  /// puddles of a corridor: docs/registration.md.
  bool label_axis_search = true;
  double label_axis_range = 2.5;       ///< m either way
  double label_axis_gate = 0.5;        ///< m
  double label_axis_min_support = 3.0;  ///< label score (≈ well-matched labelled points)
  double label_axis_ambiguity = 0.85;   ///< the next peak at most this × the best (above the profile's floor)
  double label_axis_sigma = 0.05;      ///< m; variance added along the axis when labels placed it
  double label_axis_voxel = 0.1;       ///< m; the labelled points' resolution for the search
  /// m; labels placing the frame within this of ICP's answer confirm it (ICP's answer is kept: where
  /// the geometry has anything to go by it is the finer of the two; naraha's weak-axis frames).
  double label_axis_confirm = 0.1;
  /// m; unlabelled returns this close to labelled ones take part too (a mismatch costs α): they
  /// show where a panel ends, so a partial view cannot slide along it.
  double label_axis_context = 0.5;
  /// The two halves of the labelled points (alternate points) place the frame this close (m), or
  /// the frame keeps the labels' position but stays flagged (far patches at a grazing angle).
  double label_axis_consistency = 0.05;
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

/// YAML: the keys of the field table, at top level or under `odometry:`; `map:` and
/// `registration:` are nested sections. Unknown keys are errors naming the closest valid key.
OdometryConfig odometryConfigFromYaml(const std::string& yaml, const std::string& where,
                                      const OdometryConfig& base = OdometryConfig::defaults());
OdometryConfig loadOdometryConfig(const std::string& path,
                                  const OdometryConfig& base = OdometryConfig::defaults());

enum class FrameStatus {
  First,        ///< the first frame (pose = initial pose)
  Tracked,      ///< ICP from the guess used
  Degenerate,   ///< tracked, but the guess kept along ICP's degenerate directions
  Relocalised,  ///< global registration (no guess), verified by ICP, used
  Fallback,     ///< nothing verified: the guessed increment was used; the frame is flagged
};
/// "first", "tracked", "degenerate", "relocalised", "fallback".
const char* toString(FrameStatus status);
/// One line for people, e.g. "relocalised: global registration verified by ICP".
const char* describe(FrameStatus status);
/// A frame whose pose no registration fully vouches for: fallback (nothing verified), or
/// degenerate (along some direction the pose is the guess's, not the registration's).
inline bool isFlagged(FrameStatus status) { return status == FrameStatus::Fallback || status == FrameStatus::Degenerate; }

/// The global registration tried on a frame (issue 19).
struct GlobalAttempt {
  bool tried = false;
  std::string trigger;   ///< why it was tried
  GlobalStatus status = GlobalStatus::NoConsensus;
  std::string outcome;   ///< "used", or why not (the global reason or the failed verification)
  double score = 0.0, second_best_score = 0.0;
  double milliseconds = 0.0;  ///< target preparation + global registration + verification
  /// The whole map (keyframes) was tried after several failed frames (kidnapped robot); `status`,
  /// `score` and `outcome` are then that attempt's.
  bool whole_map = false;
};

struct OdometryFrame {
  std::size_t index = 0;
  double stamp = 0.0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();       ///< world ← sensor
  Eigen::Isometry3d increment = Eigen::Isometry3d::Identity();  ///< previous ← current
  Eigen::Isometry3d guess = Eigen::Isometry3d::Identity();      ///< guessed increment
  /// Covariance of `increment` (left perturbation, translation first, previous frame).
  Matrix6d covariance = Matrix6d::Zero();
  FrameStatus status = FrameStatus::First;
  std::string reason;  ///< why the frame fell back / was degenerate
  bool wheel_guess = false;  ///< the guess came from wheel odometry (else constant velocity)
  /// The motion hypothesis ICP started from when it replaced the guess (motion_hypotheses), else empty.
  std::string guess_hypothesis;
  RegistrationResult registration;  ///< the ICP whose answer was used (or the failed one)
  GlobalAttempt global;
  std::size_t scan_points = 0, source_points = 0, map_points = 0;
  /// Wall times: preprocess = the scan's crop and downsampling (frame to map it runs beside the
  /// local map's target build); registration = the rest of the frame (target, ICP, checks, map
  /// update) = total − preprocess.
  double preprocess_ms = 0.0, registration_ms = 0.0, total_ms = 0.0;
};

/// A scan as tracking enters it into the local map (and registers it, unless source_voxel_size
/// is coarser): cropped to [min_range, max_range], downsampled to voxel_size keeping property classes.
LabeledCloud preprocessForTracking(const LabeledCloud& scan, const OdometryConfig& config, const ClassTable& classes);

class Odometry {
 public:
  Odometry(const ClassTable& classes, const OdometryConfig& config = OdometryConfig::defaults(),
           const Eigen::Isometry3d& initial_pose = Eigen::Isometry3d::Identity());
  ~Odometry();

  /// Processes the next scan (sensor frame). `wheel_increment` = previous ← current from wheel
  /// odometry, if available. Throws hazmap::Error for a class missing from the table (when
  /// classes are used) or a non-finite wheel increment; an empty scan falls back.
  const OdometryFrame& addFrame(const LabeledCloud& scan,
                                const std::optional<Eigen::Isometry3d>& wheel_increment = std::nullopt,
                                double stamp = -1.0);

  const std::vector<OdometryFrame>& frames() const { return frames_; }
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
                std::optional<RegistrationTarget>& map_target) const;
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
  /// whole_map_confirm: whether the previous frame's whole-map answer agrees with `answer`.
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
  std::vector<OdometryFrame> frames_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hazmap
