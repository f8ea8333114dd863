#include "hazmap/pipeline/slam.hpp"

#include <tbb/global_control.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <atomic>
#include <memory>
#include <mutex>

#include "hazmap/core/error.hpp"
#include "hazmap/core/retire_oldest.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/preprocess/imu_gravity.hpp"
#include "pipeline/back_end_thread.hpp"
#include "pipeline/clock.hpp"
#include "pipeline/frame_records.hpp"
#include "pipeline/graph_side.hpp"

namespace hazmap {

namespace {

using namespace pipeline_detail;

// One SLAM run, frame by frame: each public step is one box of the paper's Fig. 1. The graph's
// side runs on this thread (GraphSide) or on the back end's own (BackEndThread,
// SlamConfig::back_end own-thread); either way it gets the same frames in the same order.
class SlamRun {
 public:
  SlamRun(ScanSource& source, const SlamConfig& config, const SlamSnapshots& hooks)
      : source_(source), config_(config), deskewer_(config.deskew), on_frame_(hooks.frame),
        before_loop_stage_(hooks.loop_stage) {
    result_.method = config.method;
    result_.graph.dimension = 3;
  }

  /// The next scan; the source is locked meanwhile (the back end's thread may re-read old keyframes).
  /// Meanwhile the back end's thread may work (BackEndThread::trackingWaits).
  std::optional<Scan> next() {
    if (back_end_thread_) back_end_thread_->trackingWaits();
    std::optional<Scan> scan;
    {
      std::lock_guard<std::mutex> lock(source_lock_);
      scan = source_.next();
    }
    if (back_end_thread_ && scan) back_end_thread_->trackingBegins();
    return scan;
  }

  /// Fig. 1 for one scan: wheel-odometry guess → deskewing and (property-)ICP tracking → the
  /// graph's node and odometry edge → on keyframes, loop closure (and online optimisation).
  void addScan(Scan scan) {
    if (frames() == 0) start(scan);
    const std::optional<Eigen::Isometry3d> wheel_increment = wheelIncrement(scan);
    FrameRecord record = trackBesideLoops(scan, wheel_increment);
    const Eigen::Isometry3d pose = addToTrajectory(record);
    if (graph_) graph_->addFrame(record);
    result_.frames.push_back(std::move(record));
    const std::vector<std::size_t> changed = takeReestimatedLostFrames();
    if (graph_) graph_->replaceFrames(changed);
    const bool keyframe = isKeyframe(pose);
    if (keyframe && !scan.gravity) scan.gravity = gravityFromImu(scan);
    if (back_end_thread_) {
      passToBackEnd(scan, pose, changed, keyframe);
      return forgetOldRecords();
    }
    tellFrame(scan.cloud);
    if (!keyframe) return;
    graph_->addGravityPrior(scan.gravity);
    if (config_.back_end == BackEndSchedule::BesideTracking)
      pending_loops_.emplace(PendingLoops{frames() - 1, std::move(scan.cloud)});
    else
      closeLoops(frames() - 1, std::move(scan.cloud));
  }

  std::size_t frames() const { return first_record_ + result_.frames.size(); }

  /// The live view's hook: the frame just added, and whether earlier poses moved since the last
  /// call (an online optimisation ran beside this frame's tracking or came back from the back
  /// end's thread, or lost frames were redone).
  void tellFrame(const LabeledCloud& cloud) {
    if (!on_frame_) return;
    if (!back_end_thread_) {
      const std::size_t optimisations = result_.optimisations.size();
      if (optimisations != told_optimisations_) ++corrections_;
      told_optimisations_ = optimisations;
    }
    const std::vector<Eigen::Isometry3d>& poses = back_end_thread_ ? estimate_ : result_.graph.poses;
    const std::size_t backlog = back_end_thread_ ? back_end_thread_->backlog() : 0;
    on_frame_(SlamFrameEvent{result_.frames.back(), cloud, poses, corrections_, backlog});
  }

  /// Whether a snapshot was asked for and not yet handed over (the back end's thread has it).
  bool snapshotPending() const { return snapshot_pending_.load(std::memory_order_acquire); }

  /// The result so far, between two scans, to `hooks.take`: at once from this thread's result, or
  /// on the back end's thread once it has every frame tracked so far (tracking goes on meanwhile).
  void takeSnapshot(const SlamSnapshots& hooks) {
    if (hooks.taking) hooks.taking(frames());
    Trajectory tracked = trajectoryOf(tracked_.all());
    if (!back_end_thread_) return hooks.take(finishedAsAtTheEnd(SlamResult(result_), std::move(tracked), source_.describe()));
    snapshot_pending_.store(true, std::memory_order_release);
    back_end_thread_->snapshotOfQueued([this, take = hooks.take, tracker_side = withTrackerSide(SlamResult{}, result_),
                                        tracked = std::move(tracked), source = source_.describe()](SlamResult back) mutable {
      take(finishedAsAtTheEnd(withTrackerSide(std::move(back), tracker_side), std::move(tracked), std::move(source)));
      snapshot_pending_.store(false, std::memory_order_release);
    });
  }

  SlamResult finish() {
    Trajectory tracked = trajectoryOf(tracked_.all());  // before the back end's records replace ours
    if (back_end_thread_) {
      result_ = withTrackerSide(back_end_thread_->finish(), result_);
      first_record_ = 0;
    } else {
      runPendingLoops();
      graph_->finish();
    }
    // The source's description after the scans: a decoder knows its sensor by then.
    return finishedAsAtTheEnd(std::move(result_), std::move(tracked), source_.describe());
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
    tracker_->keepNewestFrames(0);  // the frames' records are ours (result_.frames); a long mission's memory stays bounded
    if (usesPoseGraph(config_.method) && config_.back_end == BackEndSchedule::OwnThread) {
      back_end_thread_ = std::make_unique<BackEndThread>(config_, start_, classes_, source_, source_lock_,
                                                         before_loop_stage_);
      // The run's poses and records are the back end's: ours keep the newest in memory (what
      // re-estimating lost frames rewrites), the older ones in journals (a long mission, issue 33).
      tracked_.keepNewest(2 * reestimationReach(config_.odometry.recovery));
      past_stamps_.keepNewest(1);
      past_increments_.keepNewest(1);
      return;
    }
    graph_.emplace(config_, result_, tracked_, start_);
    graph_->start(classes_, source_, nullptr);
  }

  bool hasBackEnd() const { return back_end_thread_ || (graph_ && graph_->hasBackEnd()); }

  /// A frame this far (SlamConfig::keyframe_distance / keyframe_angle) from the last keyframe
  /// (PGO methods only) becomes the next.
  bool isKeyframe(const Eigen::Isometry3d& pose) {
    if (!hasBackEnd()) return false;
    if (last_keyframe_) {
      const Eigen::Isometry3d since = last_keyframe_->inverse() * pose;
      if (translationNorm(since) < config_.keyframe_distance && rotationAngle(since) < config_.keyframe_angle) return false;
    }
    last_keyframe_ = pose;
    return true;
  }

  /// A keyframe's gravity prior from its accelerometer where the recording gives no direction of
  /// its own (gravity.txt): σ widened by how much the tracked motion accelerated.
  std::optional<GravitySample> gravityFromImu(const Scan& scan) const {
    if (scan.imu.empty() || !config_.graph.gravity_prior || !usesIcp(config_.method)) return std::nullopt;
    return gravityFromAccelerometer(scan.imu, scan.stamp, trackedAcceleration(), imu_.bias());
  }

  /// m/s²: the velocity change over the last two tracked increments (velocities in the middle
  /// frame's axes); 1 m/s² before there are two, which leaves a prior too weak to add.
  double trackedAcceleration() const {
    constexpr double kUnknown = 1.0;
    const std::size_t n = frames();
    if (n < 3 || result_.frames.size() < 3) return kUnknown;
    const FrameRecord &a = record(n - 3), &b = record(n - 2), &c = record(n - 1);
    const double dt1 = b.stamp - a.stamp, dt2 = c.stamp - b.stamp;
    if (!(dt1 > 0.0 && dt2 > 0.0)) return kUnknown;
    const Eigen::Vector3d v1 = b.T_prev_curr.linear().transpose() * b.T_prev_curr.translation() / dt1;
    const Eigen::Vector3d v2 = c.T_prev_curr.translation() / dt2;
    return (v2 - v1).norm() / (0.5 * (dt1 + dt2));
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

  /// The tracked pose (and, with the back end on its own thread, the live estimate continuing
  /// from the newest pose it has).
  Eigen::Isometry3d addToTrajectory(const FrameRecord& rec) {
    const bool first = tracked_.empty();
    tracked_.push_back(first ? start_ : normalized(tracked_.back() * rec.T_prev_curr));
    if (back_end_thread_) estimate_.push_back(first ? start_ : normalized(estimate_.back() * rec.T_prev_curr));
    return tracked_.back();
  }

  /// Issue 19 (odometry.recovery.reestimate_lost_frames): once a frame is verified again the tracker
  /// re-estimates the lost frames before it and the increments on both sides; those replace the
  /// recorded ones (record, odometry edge, tracked pose and graph node from the first changed frame
  /// on), as `hazmap odometry` writes them. Only with relocalise_suspect (the worst-day set-up):
  /// a normal run's graph stays bit for bit.
  std::vector<std::size_t> takeReestimatedLostFrames() {
    std::vector<std::size_t> changed;
    if (!tracker_ || !usesIcp(config_.method) || !config_.odometry.recovery.relocalise_suspect ||
        !config_.odometry.recovery.reestimate_lost_frames)
      return changed;
    const FrameHistory& tf = tracker_->history();
    const std::size_t n = frames(), back = reestimationReach(config_.odometry.recovery);
    for (std::size_t k = n > back ? n - back : 1; k < n && k < tf.size(); ++k)
      if (takeReestimate(record(k), tf.full(k))) changed.push_back(k);
    if (changed.empty()) return changed;
    if (changed.front() + 1 < n) ++corrections_;  // poses before the newest moved
    chain(tracked_, changed.front());
    if (back_end_thread_) chain(estimate_, changed.front());
    return changed;
  }

  /// The frame to the back end's thread (by value; a keyframe's scan moved), after the newest
  /// optimised poses it sent back were applied: at a frame boundary, so the live view sees the
  /// correction with this frame.
  void passToBackEnd(Scan& scan, const Eigen::Isometry3d& pose, const std::vector<std::size_t>& changed, bool keyframe) {
    if (const auto solution = back_end_thread_->takeSolution()) {
      const std::size_t m = std::min(solution->size(), estimate_.size());
      std::copy(solution->begin(), solution->begin() + static_cast<std::ptrdiff_t>(m), estimate_.begin());
      chain(estimate_, m);
      ++corrections_;
    }
    tellFrame(scan.cloud);
    TrackedFrame f;
    f.record = result_.frames.back();
    f.tracked_pose = pose;
    for (std::size_t k : changed) f.reestimated.push_back(record(k));
    f.keyframe = keyframe;
    if (keyframe) {
      f.gravity = scan.gravity;
      f.cloud = std::move(scan.cloud);
    }
    back_end_thread_->push(std::move(f));
  }

  /// A result's source, tracked and final trajectories (the optimised poses' stamps from its own
  /// records: this may run on the back end's thread).
  SlamResult finishedAsAtTheEnd(SlamResult r, Trajectory tracked, std::string source) const {
    r.source = std::move(source);
    r.tracked = std::move(tracked);
    if (hasBackEnd()) {
      r.estimate = Trajectory{};
      for (std::size_t i = 0; i < r.graph.poses.size(); ++i) r.estimate.push_back(r.frames.at(i).stamp, r.graph.poses[i]);
    } else {
      r.estimate = config_.method == SlamMethod::Odometry ? r.odometry_only : r.tracked;
    }
    return r;
  }

  /// The back end's result with what only the tracker knows (wheel odometry, tracking's time).
  static SlamResult withTrackerSide(SlamResult back, const SlamResult& tracker) {
    back.odometry_only = tracker.odometry_only;
    back.timings.tracking_s = tracker.timings.tracking_s;
    return back;
  }

  /// track(), with the previous keyframe's pending loop stage (if any) running beside it
  /// (SlamConfig::back_end beside-tracking). The tracker reads nothing the loop stage writes (graph,
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
    closeLoops(p.frame, std::move(p.cloud));
  }

  void closeLoops(std::size_t frame, LabeledCloud cloud) {
    if (before_loop_stage_) before_loop_stage_(frame);
    graph_->closeLoops(std::move(cloud));
  }

  Trajectory trajectoryOf(const std::vector<Eigen::Isometry3d>& poses) const {
    Trajectory t;
    JournaledList<double>::Cursor past_stamp(past_stamps_);
    for (std::size_t i = 0; i < poses.size(); ++i) t.push_back(i < first_record_ ? past_stamp(i) : record(i).stamp, poses[i]);
    return t;
  }

  FrameRecord& record(std::size_t k) { return result_.frames.at(k - first_record_); }
  const FrameRecord& record(std::size_t k) const { return result_.frames.at(k - first_record_); }

  /// poses[k] from poses[k − 1] and frame k's increment, for k from `first` on.
  template <class Poses>
  void chain(Poses& poses, std::size_t first) const {
    JournaledList<Eigen::Isometry3d>::Cursor past_increment(past_increments_);
    chainFrom(poses, first, frames(), [&](std::size_t k) -> const Eigen::Isometry3d& {
      return k < first_record_ ? past_increment(k) : record(k).T_prev_curr;
    });
  }

  /// With the back end on its own thread the run's records are the copies it was sent: ours keep
  /// the newest in full (what re-estimating lost frames rewrites) and the older ones' stamp and
  /// increment (issue 33: ~0.9 kB a frame, ~30 MB an hour at 10 scans/s), journalled.
  void forgetOldRecords() {
    first_record_ += retireOldest(result_.frames, reestimationReach(config_.odometry.recovery), [&](const FrameRecord& r) {
      past_stamps_.push_back(r.stamp);
      past_increments_.push_back(r.T_prev_curr);
    });
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
  TrackedPoses tracked_{"tracked pose journal"};
  std::optional<Eigen::Isometry3d> last_keyframe_;
  std::optional<GraphSide> graph_;  // the graph on this thread (every method records one)
  struct PendingLoops {
    std::size_t frame;
    LabeledCloud cloud;
  };
  std::optional<PendingLoops> pending_loops_;  // the newest keyframe's loop stage, not yet run
  std::function<void(const SlamFrameEvent&)> on_frame_;
  std::function<void(std::size_t)> before_loop_stage_;
  std::size_t told_optimisations_ = 0, corrections_ = 0;
  std::mutex source_lock_;
  // SlamConfig::back_end own-thread: the graph on the back end's thread, and the estimate so far as
  // the tracker knows it (the back end's newest optimised poses, then the tracked increments).
  std::atomic<bool> snapshot_pending_{false};  // set here, cleared on the back end's thread
  std::unique_ptr<BackEndThread> back_end_thread_;
  std::vector<Eigen::Isometry3d> estimate_;
  // Own thread: stamp and increment of frames 0 … first_record_ − 1 (forgetOldRecords).
  JournaledList<double> past_stamps_{"frame stamp journal"};
  JournaledList<Eigen::Isometry3d> past_increments_{"frame increment journal"};
  std::size_t first_record_ = 0;
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
  SlamRun run(source, config, snapshots);
  const std::size_t total = source.size().value_or(0);
  while (std::optional<Scan> scan = run.next()) {
    run.addScan(std::move(*scan));
    if (progress) progress(run.frames(), total);
    if (snapshots.due && snapshots.take && !run.snapshotPending() && snapshots.due()) run.takeSnapshot(snapshots);
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
