#include "hazmap/pipeline/slam.hpp"

#include <tbb/global_control.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <memory>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "pipeline/back_end.hpp"
#include "pipeline/clock.hpp"
#include "pipeline/edge_noise.hpp"
#include "pipeline/frame_records.hpp"

namespace hazmap {

namespace {

using namespace pipeline_detail;

// One SLAM run, frame by frame: each public step is one box of the paper's Fig. 1.
class SlamRun {
 public:
  SlamRun(ScanSource& source, const SlamConfig& config,
          std::function<void(const SlamFrameEvent&)> on_frame = {})
      : source_(source), config_(config), deskewer_(config.deskew), on_frame_(std::move(on_frame)) {
    result_.method = config.method;
    result_.graph.dimension = 3;
  }

  /// Fig. 1 for one scan: wheel-odometry guess → deskewing and (property-)ICP tracking → the
  /// graph's node and odometry edge → on keyframes, loop closure (and online optimisation).
  void addScan(Scan scan) {
    if (frames() == 0) start(scan);
    const std::optional<Eigen::Isometry3d> wheel_increment = wheelIncrement(scan);
    FrameRecord record = trackBesideLoops(scan, wheel_increment);
    const Eigen::Isometry3d pose = addToTrajectory(record);
    addOdometryEdge(record);
    result_.frames.push_back(std::move(record));
    takeReestimatedLostFrames();
    tellFrame(scan.cloud);
    if (!back_end_ || !back_end_->isKeyframe(pose)) return;
    back_end_->addGravityPrior(scan);
    if (config_.loops_beside_tracking)
      pending_loops_.emplace(PendingLoops{pose, std::move(scan.cloud)});
    else
      back_end_->closeLoops(pose, std::move(scan.cloud));
  }

  std::size_t frames() const { return result_.frames.size(); }

  /// The live view's hook: the frame just added, and whether earlier poses moved since the last
  /// call (an online optimisation ran beside this frame's tracking, or lost frames were redone).
  void tellFrame(const LabeledCloud& cloud) {
    if (!on_frame_) return;
    const std::size_t optimisations = result_.optimisations.size();
    if (optimisations != told_optimisations_) ++corrections_;
    told_optimisations_ = optimisations;
    on_frame_(SlamFrameEvent{result_.frames.back(), cloud, result_.graph.poses, corrections_});
  }

  /// The result so far, between two scans (nothing runs beside tracking then).
  SlamResult snapshot() const {
    SlamResult s = result_;
    s.source = source_.describe();
    s.tracked = trajectoryOf(tracked_);
    s.estimate = back_end_ ? trajectoryOf(result_.graph.poses)
                 : config_.method == SlamMethod::Odometry ? s.odometry_only
                                                          : s.tracked;
    return s;
  }

  SlamResult finish() {
    runPendingLoops();
    result_.source = source_.describe();  // after the scans: a decoder knows its sensor by then
    result_.tracked = trajectoryOf(tracked_);
    if (back_end_) {
      back_end_->finish();
      result_.estimate = trajectoryOf(result_.graph.poses);
    } else if (config_.method == SlamMethod::Odometry) {
      result_.estimate = result_.odometry_only;
    } else {
      result_.estimate = result_.tracked;
    }
    return std::move(result_);
  }

 private:
  /// The first scan fixes the common start pose (its ground truth, else its wheel odometry), the
  /// frame the wheel odometry is expressed in, and builds the tracker and the loop detector.
  void start(const Scan& first) {
    const std::string where = source_.describe();
    if (config_.method == SlamMethod::Odometry && !first.odometry)
      fail(where, "method 'odometry' needs wheel odometry (odometry.txt or an odometry topic)");
    start_ = first.ground_truth ? *first.ground_truth
             : first.odometry   ? *first.odometry
                                : Eigen::Isometry3d::Identity();
    has_odometry_ = first.odometry.has_value();
    if (has_odometry_) T_start_odom0_ = start_ * first.odometry->inverse();
    // α and the class search radii, set once for tracking and loop verification alike.
    classes_ = config_.property_icp.applyTo(source_.classTable(), where);
    tracker_.emplace(classes_, config_.odometry, start_);
    if (!usesPoseGraph(config_.method)) return;
    back_end_.emplace(config_, result_, tracked_);
    back_end_->start(classes_, source_);
  }

  /// Wheel odometry from the common start pose; the increment from the previous scan.
  std::optional<Eigen::Isometry3d> wheelIncrement(const Scan& scan) {
    if (!has_odometry_) return std::nullopt;
    if (!scan.odometry)
      fail(source_.describe(), "scan " + std::to_string(scan.index) +
                                   " has no wheel odometry while the first scan had some");
    const Eigen::Isometry3d pose = normalized(T_start_odom0_ * *scan.odometry);
    result_.odometry_only.push_back(scan.stamp, pose);
    const auto& poses = result_.odometry_only.poses;
    if (poses.size() < 2) return std::nullopt;
    return poses[poses.size() - 2].inverse() * poses.back();
  }

  /// Deskewing, then (property-)ICP against the previous scan or the local map with the wheel
  /// increment as the initial guess (the odometry method takes the wheel increment as it is).
  FrameRecord track(Scan& scan, const std::optional<Eigen::Isometry3d>& wheel_increment) {
    const auto t_frame = Clock::now();
    FrameRecord rec;
    rec.index = frames();
    rec.stamp = scan.stamp;
    if (!usesIcp(config_.method)) {
      if (wheel_increment) rec.T_prev_curr = *wheel_increment;
    } else {
      const ImuStreamMotion::Motion imu = imu_.next(scan.imu, scan.stamp);
      rec.deskew_velocity = deskewer_.apply(scan.cloud, scan.stamp, wheel_increment, imu.attitudePtr());
      const OdometryFrame& f = tracker_->addFrame(scan.cloud, wheel_increment, scan.stamp, imu.rotation);
      deskewer_.tracked(f.increment);
      imu_.tracked(verifiedRotation(f));
      recordTracking(rec, f, config_.odometry.mode);
    }
    rec.milliseconds = 1e3 * secondsSince(t_frame);
    result_.timings.tracking_s += secondsSince(t_frame);
    return rec;
  }

  /// The tracked pose, and the graph's new node continuing from the (possibly already
  /// optimised) previous node. Every method records its graph (graph.g2o).
  Eigen::Isometry3d addToTrajectory(const FrameRecord& rec) {
    const bool first = tracked_.empty();
    tracked_.push_back(first ? start_ : normalized(tracked_.back() * rec.T_prev_curr));
    PoseGraph& graph = result_.graph;
    graph.addNode(first ? start_ : normalized(graph.poses.back() * rec.T_prev_curr));
    return tracked_.back();
  }

  /// Odometry edge, information = inverse of the calibrated ICP covariance (eq. 3), or the wheel
  /// noise when the tracker fell back to the encoders. The covariance is kept for the gate.
  void addOdometryEdge(const FrameRecord& rec) {
    if (rec.index == 0) {
      if (back_end_) back_end_->addStep(rec, Matrix6d::Zero());
      return;
    }
    const EdgeNoise noise = odometryEdgeNoise(rec, config_);
    if (back_end_) back_end_->addStep(rec, noise.covariance);
    result_.graph.addEdge(static_cast<int>(rec.index - 1), static_cast<int>(rec.index), rec.T_prev_curr,
                          noise.information, EdgeKind::Odometry);
  }

  /// Issue 19 (odometry.recovery.reestimate_lost_frames): once a frame is verified again the tracker
  /// re-estimates the lost frames before it and the increments on both sides; those replace the
  /// recorded ones (record, odometry edge, tracked pose and graph node from the first changed frame
  /// on), as `hazmap odometry` writes them. Only with relocalise_suspect (the worst-day set-up):
  /// a normal run's graph stays bit for bit.
  void takeReestimatedLostFrames() {
    if (!tracker_ || !usesIcp(config_.method) || !config_.odometry.recovery.relocalise_suspect ||
        !config_.odometry.recovery.reestimate_lost_frames)
      return;
    const std::vector<OdometryFrame>& tf = tracker_->frames();
    const std::size_t n = result_.frames.size(), back = static_cast<std::size_t>(config_.odometry.recovery.lost_frames_max) + 2;
    std::size_t first = n;
    for (std::size_t k = n > back ? n - back : 1; k < n && k < tf.size(); ++k) {
      FrameRecord& rec = result_.frames[k];
      if (!takeReestimate(rec, tf[k])) continue;
      const EdgeNoise noise = odometryEdgeNoise(rec, config_);
      if (back_end_) back_end_->replaceStep(k, noise.covariance);
      for (PoseGraphEdge& e : result_.graph.edges)
        if (e.kind == EdgeKind::Odometry && e.from == static_cast<int>(k - 1) && e.to == static_cast<int>(k)) {
          e.T_from_to = rec.T_prev_curr;
          e.information = noise.information;
        }
      first = std::min(first, k);
    }
    if (first + 1 < n) ++corrections_;  // poses before the newest moved
    for (std::size_t k = first; k < n; ++k) {
      tracked_[k] = normalized(tracked_[k - 1] * result_.frames[k].T_prev_curr);
      result_.graph.poses[k] = normalized(result_.graph.poses[k - 1] * result_.frames[k].T_prev_curr);
    }
  }

  /// track(), with the previous keyframe's pending loop stage (if any) running beside it
  /// (SlamConfig::loops_beside_tracking). The tracker reads nothing the loop stage writes (graph,
  /// keyframes, loops) and the loop stage nothing the tracker writes, and the next scan's node and
  /// edges join the graph only after both finished, so the results are the same bit for bit.
  FrameRecord trackBesideLoops(Scan& scan, const std::optional<Eigen::Isometry3d>& wheel_increment) {
    if (!pending_loops_) return track(scan, wheel_increment);
    FrameRecord record;
    tbb::parallel_invoke([&] { record = track(scan, wheel_increment); }, [&] { runPendingLoops(); });
    return record;
  }

  void runPendingLoops() {
    if (!pending_loops_) return;
    PendingLoops p = std::move(*pending_loops_);
    pending_loops_.reset();
    back_end_->closeLoops(p.pose, std::move(p.cloud));
  }

  Trajectory trajectoryOf(const std::vector<Eigen::Isometry3d>& poses) const {
    Trajectory t;
    for (std::size_t i = 0; i < poses.size(); ++i) t.push_back(result_.frames[i].stamp, poses[i]);
    return t;
  }

  ScanSource& source_;
  const SlamConfig& config_;
  SlamResult result_;
  Eigen::Isometry3d start_ = Eigen::Isometry3d::Identity();
  ClassTable classes_;
  bool has_odometry_ = false;
  Eigen::Isometry3d T_start_odom0_ = Eigen::Isometry3d::Identity();
  StreamDeskewer deskewer_;
  ImuStreamMotion imu_;
  std::optional<Odometry> tracker_;
  std::vector<Eigen::Isometry3d> tracked_;
  std::optional<BackEnd> back_end_;  // PGO methods only
  struct PendingLoops {
    Eigen::Isometry3d pose;
    LabeledCloud cloud;
  };
  std::optional<PendingLoops> pending_loops_;  // the newest keyframe's loop stage, not yet run
  std::function<void(const SlamFrameEvent&)> on_frame_;
  std::size_t told_optimisations_ = 0, corrections_ = 0;
};

}  // namespace

SlamResult runSlam(ScanSource& source, const SlamConfig& config, const FrameProgress& progress) {
  return runSlam(source, config, progress, SlamSnapshots{});
}

SlamResult runSlam(ScanSource& source, const SlamConfig& config, const FrameProgress& progress,
                   const SlamSnapshots& snapshots) {
  config.validate();
  std::optional<tbb::global_control> threads;
  if (config.threads > 0)
    threads.emplace(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(config.threads));
  const auto t_start = Clock::now();
  SlamRun run(source, config, snapshots.frame);
  const std::size_t total = source.size().value_or(0);
  while (std::optional<Scan> scan = source.next()) {
    run.addScan(std::move(*scan));
    if (progress) progress(run.frames(), total);
    if (snapshots.due && snapshots.take && snapshots.due()) snapshots.take(run.snapshot());
  }
  if (run.frames() == 0) fail(source.describe(), "has no scans");
  SlamResult result = run.finish();
  result.timings.total_s = secondsSince(t_start);
  return result;
}

SlamResult runSlam(const Sequence& sequence, const SlamConfig& config, const FrameProgress& progress) {
  const auto source = sequenceScanSource(sequence, /*read_channels=*/false);  // tracking needs no channels
  return runSlam(*source, config, progress);
}

}  // namespace hazmap
