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

/// When the graph's side of a keyframe runs relative to tracking (SlamConfig::back_end).
enum class BackEndSchedule { AfterFrame, BesideTracking, OwnThread };

struct SlamConfig {
  SlamMethod method = SlamMethod::PropertyIcpPgo;
  /// Tracking: preprocessing, (property-)ICP, local map, failure detection. The paper registers
  /// frame to frame; hazmap's default is frame to local map (see forMethod).
  OdometryConfig odometry = OdometryConfig::defaults();
  /// Floors on an ICP increment's standard deviations before its covariance is inverted into an
  /// odometry-edge information (m, rad): an over-confident covariance must not make edges rigid.
  double min_translation_sigma = 0.005;
  double min_rotation_sigma = 0.0005;
  /// Gate verified loops by the calibrated χ² innovation test against the covariance the graph
  /// itself gives the keyframes' relative pose (loop/consistency.hpp); false = the drift model.
  bool innovation_gate = true;
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
  /// Beyond this many frames the online solves are of the keyframes' graph (graph/keyframe_graph.hpp:
  /// the odometry chains between keyframes folded, the frames between moved with their keyframe;
  /// the end solves the whole graph). On a 0.1 m-per-frame route that is a ninth of the nodes: at
  /// 36,000 frames a solve of the whole graph held ~290 MB of Ceres' working memory and took
  /// 2–3 s (docs/live.md). 0 = always the whole graph.
  std::size_t online_keyframe_graph_after = 4000;
  /// When a keyframe's loop stage (search, verification, optimisation) runs; every schedule gives
  /// the same final answer bit for bit. BesideTracking: while the next scan is tracked, the two
  /// sharing the threads (the next scan's node joins the graph after both). OwnThread: the whole
  /// back end on a thread of its own, so tracking never waits for a loop stage and the optimised
  /// poses come back to it at a frame boundary (`hazmap live`'s default; the estimate during the
  /// run lags the loops by the back end's delay). AfterFrame: before the next scan (the reference).
  BackEndSchedule back_end = BackEndSchedule::BesideTracking;
  /// With OwnThread: keyframe scans waiting for the back end, at most (MiB); beyond it
  /// tracking waits (memory stays bounded when the back end cannot keep up with the sensor).
  double back_end_queue_mb = 256.0;
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
  /// the increment's error (run.json tracking.stalled_frames).
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
/// Copies of a running SLAM's result (what `hazmap live` autosaves): `due` is asked after each
/// frame; when it answers yes, `taking` (optional) is told how many frames the copy holds, and
/// `take` gets the result of those frames as the end of the run would give it, without the final
/// optimisation (the graph as optimised online so far). Both on the pipeline's thread, except with
/// the back end on its own thread (SlamConfig::back_end own-thread): then `take` is called on the
/// back end's thread once its graph has those frames, and tracking goes on meanwhile (it never
/// waits for a loop stage to end). `due` is not asked again until `take` has returned.
/// `frame` (optional) is told of each frame as it joins the graph (what the live view draws):
/// cheap work only, it runs on the pipeline's thread.
struct SlamFrameEvent {
  const FrameRecord& record;
  const LabeledCloud& scan;  ///< sensor frame, deskewed as tracking saw it
  /// The graph's poses so far (T_world_sensor; optimised online after accepted loops).
  const std::vector<Eigen::Isometry3d>& poses;
  /// Counts changes to poses before the newest (an online optimisation, re-estimated lost
  /// frames): when it moves, the whole trajectory was redrawn.
  std::size_t corrections = 0;
  /// Frames tracked but not yet in the back end's graph (SlamConfig::back_end own-thread: it is
  /// behind, typically verifying loops); 0 in the synchronous schedule.
  std::size_t back_end_backlog = 0;
};
struct SlamSnapshots {
  std::function<bool()> due;
  std::function<void(std::size_t frames)> taking;
  std::function<void(SlamResult)> take;  ///< by value: the snapshot is the hook's to keep
  std::function<void(const SlamFrameEvent&)> frame;
  /// (Optional; tests) called with a keyframe's frame index just before its loop stage, on the
  /// thread that runs it (the back end's with SlamConfig::back_end own-thread).
  std::function<void(std::size_t frame)> loop_stage;
};
SlamResult runSlam(ScanSource& source, const SlamConfig& config, const FrameProgress& progress,
                   const SlamSnapshots& snapshots);
/// The same over a sequence folder.
SlamResult runSlam(const Sequence& sequence, const SlamConfig& config,
                   const FrameProgress& progress = {});

/// A scan as tracking saw it: deskewed again with the velocity `record` says it was deskewed with
/// (for passes over the scans after the run: keyframe reloads, the map).
void redoDeskew(LabeledCloud& cloud, const FrameRecord& record);

}  // namespace hazmap
