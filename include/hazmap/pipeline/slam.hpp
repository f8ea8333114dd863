#pragma once
// The whole SLAM run over a stream of scans (paper Fig. 1): wheel-odometry guess → deskewing →
// (property-)ICP tracking → property-landmark (or distance) loop closure → pose-graph
// optimisation with information = inverse ICP covariance (eq. 3). The scans come one at a time
// from a ScanSource (a sequence folder, a bag, a capture), so memory is bounded by the map and
// the keyframes, not by the recording. Plain data in, plain data out; writing files is
// run_outputs.hpp's job.
#include <Eigen/Geometry>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "hazmap/core/config_fwd.hpp"
#include "hazmap/core/property_icp_config.hpp"
#include "hazmap/graph/optimizer.hpp"
#include "hazmap/graph/pose_graph.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/loop/loop_closure.hpp"
#include "hazmap/pipeline/slam_method.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/preprocess/deskew.hpp"
#include "hazmap/sources/scan_source.hpp"

namespace hazmap {

/// Uncertainty of a wheel-odometry increment, used for the odometry edges of frames where ICP
/// failed and the tracker fell back to the encoders. Deliberately loose (crawler tracks slip).
struct WheelOdometryNoise {
  double translation_sigma = 0.3;  ///< m, x and y
  double vertical_sigma = 0.05;    ///< m, z
  double yaw_sigma = 0.03;         ///< rad
  double tilt_sigma = 0.02;        ///< rad, roll and pitch
  Matrix6d information() const;
};

/// The final accept test's outcome (SlamConfig::final_accept_test).
struct FinalAcceptTest {
  bool tested = false;  ///< false: off, or no loop edge (the graph is tracking's chain)
  /// A verified loop contradicts tracking's trajectory beyond the χ² gate (then tracking is no
  /// alternative and the entropies are not computed); the largest loop d² against it.
  bool loops_contradict_tracking = false;
  double worst_loop_d2 = 0.0;
  double optimised_entropy = 0.0, tracking_entropy = 0.0;  ///< mean map entropy of the keyframes' map
  bool kept_optimised = true;
};

struct SlamConfig {
  SlamMethod method = SlamMethod::PropertyIcpPgo;
  /// Tracking: preprocessing, (property-)ICP, local map, failure detection. The paper registers
  /// frame to frame; hazmap's default is frame to local map (see forMethod).
  OdometryConfig odometry = OdometryConfig::defaults();
  /// Floors on an ICP increment's standard deviations before its covariance is inverted into an
  /// odometry-edge information (m, rad): an over-confident covariance must not make edges rigid.
  double min_translation_sigma = 0.005;
  double min_rotation_sigma = 0.0005;
  /// How the floors apply: false = each diagonal entry raised to the floor (a combination of
  /// axes may still claim far less: tanks' degenerate frames claimed 0.1-0.3 mm along
  /// yaw-with-translation); true = the floor's covariance added to the increment's, so every
  /// direction carries at least the floor (an error no Hessian sees: the map's own, the
  /// correlation of neighbouring scans' residuals).
  bool additive_floor = false;
  /// Along the directions a registration could fix only through labelled patches
  /// (RegistrationResult::label_only_directions: a corridor's axis), σ (m) added to the
  /// increment's covariance (0 = off): there a scan may lock onto a patch half a patch away
  /// (corridor odometry edges 30-80 cm off along the axis, claiming 1 cm). As for loops
  /// (loop_closure.verification.label_only_sigma). Also chained into the map anchors.
  double label_only_sigma = 0.0;
  /// Calibration of the odometry edges against the simulator's truth (issue 14, NEES fitted on
  /// some seeds, checked on others; docs/pose_graph.md): Σ_edge = scale · floored Σ_ICP, plus
  /// (motion_disagreement_weight · d)² per axis, d = how far the increment is from the previous one
  /// (constant velocity), translation and rotation parts: a registration that stalled in a
  /// wrong basin after a wheel slip is a jump the motion model does not believe.
  double odometry_covariance_scale = 1.0;
  double motion_disagreement_weight = 0.0;
  /// Honest odometry edges (frame-to-map tracking; issue 14, docs/pose_graph.md 2026-12-02): a
  /// model of each increment's error fitted by NEES on odd seeds and checked on even ones. The
  /// registration's covariance gets an additive floor (every direction, so no combination of axes
  /// claims less: tanks' degenerate frames claimed 0.1 mrad in a yaw-with-translation direction
  /// and were 5-25 mrad off) instead of the diagonal floor above, and a frame whose increment a
  /// motion prior contradicts beyond a χ²(3) bound on x, y, yaw (odometry_gate_probability) is a
  /// possible wrong basin: its covariance also carries that disagreement δ (δδᵀ) and, for the
  /// wheels, their nominal noise. Two priors: the wheel increment (catches ICP in a wrong basin
  /// while the wheels were right: corridor frames 30-50 cm off along the axis, the frame after a
  /// slip that snaps back) and constant velocity, the previous increment (catches ICP that
  /// followed a slipped wheel guess: both agree and are 40 cm off). Tracking is untouched; the
  /// loop gate's chain and the map anchors keep the registration covariance (slam.min_*_sigma).
  /// Off by default: honest per edge, the edges made the graph worse (naraha property-icp+pgo
  /// mean, corridor 3, tanks 1 and 2; docs/pose_graph.md): a doubtful edge modelled as one wide
  /// Gaussian becomes the hinge where loops and priors bend a chain that was right there.
  bool honest_odometry_edges = false;
  double odometry_floor_translation = 0.002;  ///< m, added in every direction
  double odometry_floor_rotation = 0.0002;    ///< rad, likewise
  /// σ growing with the frame's turn (m and rad per rad of yaw increment), added to x, y and to
  /// yaw: a scan deskewed with the wheels' yaw rate (their skid is a share of the turn) is bent
  /// in proportion to the turn, and so is where ICP places it (the tanks' 0.25 rad turning
  /// frames were 5-25 mrad and 3-10 cm off while claiming 0.1-0.5 mrad and 2-5 mm).
  double odometry_turn_translation = 0.2;
  double odometry_turn_rotation = 0.05;
  double odometry_gate_probability = 0.99;    ///< χ²(3) quantile beyond which a prior contradicts the increment
  /// The wheel slip model's nominal part (the encoders without a slip; sim/odometry_noise.hpp's
  /// specification): σ_forward = fraction × step + sigma, lateral σ, σ_yaw = sigma + fraction × |turn|.
  double wheel_gate_forward_fraction = 0.05;
  double wheel_gate_forward_sigma = 0.01;  ///< m
  double wheel_gate_lateral_sigma = 0.03;  ///< m
  double wheel_gate_yaw_sigma = 0.0044;    ///< rad (0.25 deg)
  double wheel_gate_turn_fraction = 0.05;
  /// Constant velocity: how much an increment may differ from the previous one without doubt.
  double velocity_gate_translation_sigma = 0.05;  ///< m
  double velocity_gate_rotation_sigma = 0.02;     ///< rad
  /// honest_odometry_edges: a doubtful edge as a max-mixture (graph/pose_graph.hpp,
  /// PoseGraphEdge::alt_weight; Olson & Agarwal 2013) of the tight Gaussian (floor and turn terms)
  /// and the wide wrong-basin one (with δδᵀ), instead of the wide one alone: a right increment that
  /// a prior flagged (naraha: the starts and ends of turns) stays stiff unless the loops disagree
  /// with it by more than its tight component explains (docs/pose_graph.md 2026-12-02, `mm14`).
  bool odometry_edge_mixture = false;
  /// Prior probability of the wrong-basin component of a doubtful edge, fitted on seeds 1, 3, 5, 7
  /// of the three scenes: the share of doubtful increments whose NEES against the tight component
  /// exceeds 20 (naraha 0.02, corridor 0.62, tanks 0.57; pooled 0.37).
  double odometry_mixture_weight = 0.37;
  /// Loops that share an error (issue 14, docs/pose_graph.md 2026-12-02, branch `loopcov15`):
  /// loops within loop_bias_window keyframes of one another at both ends registered nearly the
  /// same old submap from nearly the same place, and their errors against the truth are
  /// correlated (naraha, seeds 1-8: ρ ≈ 0.2-0.6 on y, z and the rotations for neighbours, ≈ 0
  /// beyond 3 keyframes). With loop_bias each such group passes through one bias node of the
  /// graph (PoseGraph::biases, prior σ = loop_shared_sigma_*), and each loop edge carries its own
  /// part only: the registration's covariance (with its misfit, probe and label-only terms) plus
  /// loop_own_sigma_* in place of the verification floor (loop_closure.verification.min_*_sigma,
  /// which still gates). Its marginal covariance (own + shared) is what graph.g2o and the loop
  /// NEES report. Off by default (see the docs for the maps).
  bool loop_bias = false;
  std::size_t loop_bias_window = 2;        ///< keyframes, at both ends, from the group's first loop
  /// Fitted on naraha seeds 1, 3, 5, 7 (both methods; corridor and tanks cannot tell: see the docs).
  double loop_own_sigma_translation = 0.0008;    ///< m, added to each loop's own covariance
  double loop_own_sigma_rotation = 0.00015;      ///< rad, likewise
  double loop_shared_sigma_translation = 0.0004;  ///< m, the bias node's prior σ
  double loop_shared_sigma_rotation = 0.0001;     ///< rad, likewise
  /// loop_bias: each loop edge a max-mixture (PoseGraphEdge::alt_weight) of its own part and a
  /// tail component (own + loop_tail_sigma_*²) of prior weight loop_tail_weight (0 = one Gaussian).
  /// Property-ICP loops on naraha have a tail the registration does not predict: 16-27 % of them
  /// are 5-45 mm / 1-8 mrad off (RMS per axis ≈ 10 mm / 1.8 mrad) where the rest are 1-2 mm off.
  double loop_tail_weight = 0.0;
  double loop_tail_sigma_translation = 0.01;  ///< m
  double loop_tail_sigma_rotation = 0.002;    ///< rad
  /// Gate verified loops by the calibrated χ² innovation test against the covariance the graph
  /// itself gives the keyframes' relative pose (loop/consistency.hpp); false = the drift model.
  bool innovation_gate = true;
  /// Loop submaps (loop_closure.submap_keyframes) only when tracking is frame-to-map: a submap
  /// placed with frame-to-frame increments is blurred by their local drift, and verifying against
  /// it was measured worse than against the matched scan alone (naraha seed 1, paper's set-up:
  /// icp+pgo 0.142 → 0.161 m; docs/pose_graph.md). true = frame-to-frame verifies scan to scan.
  bool submaps_only_frame_to_map = true;
  /// The loop covariance's misfit term (loop_closure.verification.misfit_scale) only when tracking
  /// is frame-to-map: there the loops claimed more than they had (loop NEES mean 4.9, tail to 80,
  /// and the wrong ones pulled an accurate map-anchored track); scan-to-scan loops in the paper's
  /// set-up were already timid (NEES 0.5) and correct a drifting chain — with the term, naraha
  /// seed 1 frame-to-frame property-icp+pgo went 0.1135 → 0.1335 m (docs/pose_graph.md).
  bool misfit_only_frame_to_map = true;
  /// Camera-label loops (loop_closure.partial_nearest_keyframe) verified at the matched stretch's
  /// keyframe nearest the query only when tracking is frame-to-map: there a loop from 9–13 m away
  /// is less accurate than the map-anchored track and biased it (naraha camera labels, PGO worse
  /// than tracking on seeds 2, 5, 7, 8). In the paper's set-up the nearest-keyframe loops were all
  /// within 1 cm of the truth yet the maps got worse on all eight seeds (tracking's pitch drift is
  /// the same on the retraced stretch, so pointwise loops cannot see it; docs/properties.md).
  bool nearest_partial_loops_only_frame_to_map = true;
  /// Map-anchor edges (frame-to-map tracking only): at each keyframe, an edge to the nearest
  /// keyframe within anchor_radius (m, in the tracked poses) that is at least
  /// loop_closure.candidates.min_index_gap keyframes older. Frame-to-map tracking registered the
  /// keyframe against a map holding that keyframe's points, so their tracked relative pose is a
  /// measurement as good as one registration — not the random walk the chain of increments
  /// implies. Covariance = the keyframe's calibrated ICP covariance + diag(anchor_sigma²).
  /// 0 = off.
  double anchor_radius = 8.0;
  double anchor_sigma_translation = 0.02;  ///< m
  double anchor_sigma_rotation = 0.002;    ///< rad
  /// The map follows the graph (frame-to-map, PGO methods): after every applied optimisation that
  /// moved a frame by more than reanchor_min_shift (m), the tracker's local map points move with
  /// their frames' corrections and tracking continues from the optimised pose
  /// (Odometry::reanchor; measured in docs/pose_graph.md).
  bool reanchor_map = false;
  /// The final accept test: at the end of a run the optimised trajectory is kept only when the
  /// keyframes' map it places is at least as crisp (mean map entropy, map_entropy) as the one
  /// tracking alone places; otherwise tracking's trajectory is the estimate (run.json says so).
  bool final_accept_test = false;
  /// Honest edges: a stalled frame's odometry edge (FrameRecord::stalled) gets the wheel-odometry
  /// covariance, not ICP's Hessian one (which claims mm on a registration that stopped short).
  bool stalled_edges_use_wheel_noise = false;
  /// A map-anchor edge's covariance also carries the chained covariance of the unverified
  /// increments (fallback, stalled) between its keyframes.
  bool anchors_carry_unverified_steps = false;
  /// A map-anchor edge's covariance also carries the chained covariance of every increment's
  /// share that no registration vouched for (FrameRecord::guess_covariance: a fallback's whole
  /// covariance, a degenerate frame's along the directions where the guess was kept): along
  /// those directions the tracker dead-reckoned, so its map places the newer keyframe relative
  /// to the older one no better than the chained guesses (tanks seed 8: anchors 25-42 cm and
  /// 20-38 mrad off, claiming 2-3 cm, turned the whole route 5 deg; docs/pose_graph.md).
  bool anchors_carry_guess_directions = true;
  /// The anchors' chained dead-reckoned parts (above) are one error shared by all anchors whose
  /// spans overlap: each one's is multiplied by how many overlap it, so that together they claim
  /// it once (covariance intersection; corridor seed 3: 20-odd anchors held the return 30-90 cm
  /// off along the axis against right loops, property-icp+pgo 0.57 m against tracking's 0.54).
  bool anchors_share_drift = true;
  double map_entropy_radius = 0.3;  ///< m, the entropy's neighbourhood (MapEntropyConfig::radius)
  double reanchor_min_shift = 0.005;
  /// α and the class search radii (paper eq. 2), applied to the sequence's class table that
  /// tracking and loop verification share.
  PropertyIcpConfig property_icp;
  LoopClosureConfig loop_closure; ///< PGO methods only; candidate method follows `method`
  PoseGraphConfig graph;          ///< geodesic cost, Cauchy loss on loop edges
  WheelOdometryNoise wheel_noise;
  /// A frame becomes a loop-closure keyframe after this much travel (m) or turn (rad).
  double keyframe_distance = 0.9;
  double keyframe_angle = 0.2;
  /// Re-optimise the graph as soon as a loop is accepted (online), and once at the end.
  bool optimise_online = true;
  /// Online cost (issue 14): loops are searched on every loop_search_every-th keyframe, and after
  /// a keyframe whose search accepted a loop the next loop_pause_after_accept keyframes are not
  /// searched (along a revisited stretch every keyframe would otherwise close a loop to its old
  /// neighbour; docs/measurements.md has the cost and the map errors). 1 and 0 = every keyframe.
  std::size_t loop_search_every = 1;
  std::size_t loop_pause_after_accept = 0;
  /// Run a keyframe's loop stage (search, verification, optimisation) while the next scan is
  /// tracked, the two sharing the threads; same results bit for bit (the next scan's node joins
  /// the graph after both). Ignored with reanchor_map (tracking then needs the optimised map).
  bool loops_beside_tracking = true;
  int threads = 0;  ///< 0 = TBB default
  /// Motion compensation of scans with per-point times (spinning LiDARs in bags and captures;
  /// sequence folders of .bin scans have no times and are never touched).
  DeskewConfig deskew;

  /// Defaults for a method: classes on/off in tracking and verification, loop candidates by
  /// property constellations (property methods) or by distance (conventional baseline).
  static SlamConfig forMethod(SlamMethod method);
  /// Applies a YAML file with optional sections `odometry:`, `property_icp:`, `loop_closure:`,
  /// `graph:`, `wheel_noise:`, `slam:` (keyframe_distance, keyframe_angle, optimise_online,
  /// min_translation_sigma, min_rotation_sigma) on top of the current values (the method's
  /// defaults). Errors name the file and key (docs/configuration.md lists them all).
  void applyYamlFile(const std::filesystem::path& path);
  void applyYamlString(const std::string& yaml, const std::string& where);
  /// One `section.key=value` override (value in YAML syntax), e.g. "odometry.mode=frame".
  void applySetting(const std::string& assignment);
  void validate() const;
};

/// Field tables (keys, ranges, docs; core/config_fields.hpp, docs/configuration.md).
const ConfigFields<SlamConfig>& configFields(ConfigTag<SlamConfig>);
const ConfigFields<WheelOdometryNoise>& configFields(ConfigTag<WheelOdometryNoise>);

struct FrameRecord {
  std::size_t index = 0;
  double stamp = 0.0;  ///< the scan's time (s; the frame index for folders without times.txt)
  Eigen::Isometry3d T_prev_curr = Eigen::Isometry3d::Identity();  ///< tracked increment
  Matrix6d covariance = Matrix6d::Identity();                     ///< of the increment
  bool icp_used = false;   ///< false: the wheel-odometry increment was used
  /// Which path produced the increment (tracked, degenerate, relocalised, fallback); `first` for
  /// frame 0 and for methods without ICP.
  FrameStatus status = FrameStatus::First;
  std::string fallback_reason;  ///< why the frame fell back, was relocalised or degenerate
  double fitness = 0.0, rmse = 0.0;
  int iterations = 0;
  /// ICP stopped at its iteration limit and its answer was used (tracked or degenerate): it
  /// stalled short of a minimum, typically after a wheel slip, so only the wheel odometry bounds
  /// the increment's error (its odometry edge gets wheel_noise when stalled_edges_use_wheel_noise).
  bool stalled = false;
  double milliseconds = 0.0;  ///< preprocessing + registration of this frame
  std::size_t points = 0;     ///< after preprocessing
  /// Body-frame velocity the scan was deskewed with (so a second pass over the scans can redo
  /// it); nullopt when it was not deskewed.
  std::optional<Vector6d> deskew_velocity;
  /// The share of `covariance` no registration vouches for (frame to map): all of it for a
  /// fallback, the part the tracker added along the directions where it kept the guess for a
  /// degenerate frame (covariance − the registration's own, its positive part); zero otherwise.
  Matrix6d guess_covariance = Matrix6d::Zero();
  /// Σ u uᵀ over the registration's label-only directions u, in the increment's frame
  /// (SlamConfig::label_only_sigma scales it); zero when there are none.
  Matrix6d label_only_directions = Matrix6d::Zero();
  /// The wheel-odometry increment of this frame (its guess), when the recording has one.
  std::optional<Eigen::Isometry3d> wheel_increment;
  /// SlamConfig::honest_odometry_edges: which motion prior contradicted the increment beyond the
  /// χ² bound ("wheel", "velocity", both joined by '+'; empty = none): its edge carries the doubt.
  std::string edge_doubt;
};

struct LoopRecord {
  std::size_t from_frame = 0, to_frame = 0;
  std::string source;  ///< constellation / distance
  double fitness = 0.0, rmse = 0.0;
};

/// A loop that was verified or proposed but not applied, and why (run.json).
struct LoopRejectionRecord {
  std::size_t from_frame = 0, to_frame = 0;
  LoopRejection reason = LoopRejection::None;
  std::string detail;
};

/// What became of one optimisation: applied, or the previous estimate kept and why.
struct OptimisationOutcome {
  bool applied = true;
  std::string note;  ///< empty when applied cleanly
};
/// Frames per tracking status (ICP methods; frame 0 counts as tracked).
struct TrackingCounts {
  std::size_t tracked = 0, relocalised = 0, fallback = 0;
};
TrackingCounts countTracking(const std::vector<FrameRecord>& frames);

struct SlamTimings {
  double tracking_s = 0.0, loop_s = 0.0, graph_s = 0.0, total_s = 0.0;
};

struct SlamResult {
  SlamMethod method = SlamMethod::PropertyIcpPgo;
  std::string source;        ///< ScanSource::describe() of the input
  Trajectory estimate;       ///< final (optimised when PGO ran), T_world_sensor per frame
  Trajectory tracked;        ///< before pose-graph optimisation
  Trajectory odometry_only;  ///< wheel odometry, same start pose
  std::vector<FrameRecord> frames;
  PoseGraph graph;           ///< nodes = frames
  std::vector<LoopRecord> loops;
  std::size_t keyframes = 0, loop_candidates = 0, loops_verified = 0;
  std::size_t loop_light_verifications = 0;  ///< loops that took over a checked neighbour's reverse cross-check verdict; their probes ran (loop_closure.light_duplicate_keyframes)
  std::size_t submap_targets_built = 0;  ///< verification targets built (the rest reused: submap_reuse_tolerance)
  std::size_t keyframes_searched = 0;  ///< keyframes whose loops were searched (SlamConfig::loop_search_every)
  std::vector<PoseGraphReport> optimisations;
  std::vector<OptimisationOutcome> optimisation_outcomes;  ///< one per optimisation
  std::vector<LoopRejectionRecord> rejected_loops;
  std::vector<std::pair<std::size_t, std::size_t>> anchors;  ///< map-anchor edges (from, to frame)
  FinalAcceptTest final_accept;
  std::size_t reanchors = 0;  ///< times the tracker's local map followed an optimisation (reanchor_map)
  SlamTimings timings;
  double framesPerSecond() const;
};

/// Called after each frame; `total` is 0 when the source does not know its length (a bag).
using FrameProgress = std::function<void(std::size_t done, std::size_t total)>;

/// Runs `config.method` over the scans of `source`, reading each once. The start pose is the
/// first scan's ground truth when the recording has one (so estimate and truth share a frame, as
/// in the paper), else its wheel odometry, else identity. Throws hazmap::Error naming the source
/// on unusable input (e.g. the odometry method without wheel odometry).
SlamResult runSlam(ScanSource& source, const SlamConfig& config, const FrameProgress& progress = {});
/// The same over a sequence folder.
SlamResult runSlam(const Sequence& sequence, const SlamConfig& config,
                   const FrameProgress& progress = {});

/// A scan as tracking saw it: deskewed again with the velocity `record` says it was deskewed with
/// (for passes over the scans after the run: keyframe reloads, the map).
void redoDeskew(LabeledCloud& cloud, const FrameRecord& record);

}  // namespace hazmap
