#include "hazmap/pipeline/slam.hpp"

#include <tbb/global_control.h>
#include <tbb/parallel_invoke.h>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/graph/chain_covariance.hpp"
#include "hazmap/graph/costs.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "pipeline/keyframe_spill.hpp"
#include "pipeline/loop_schedule.hpp"

namespace hazmap {

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// A floor on the standard deviations before inverting a covariance: an over-confident ICP
// covariance (few, noise-free points) must not make an edge rigid. Returned with its eigenvalues
// bounded below, so that it inverts.
Matrix6d flooredCovariance(const Matrix6d& covariance, double min_translation_sigma, double min_rotation_sigma) {
  Matrix6d c = 0.5 * (covariance + covariance.transpose());
  for (int i = 0; i < 3; ++i) c(i, i) = std::max(c(i, i), min_translation_sigma * min_translation_sigma);
  for (int i = 3; i < 6; ++i) c(i, i) = std::max(c(i, i), min_rotation_sigma * min_rotation_sigma);
  Eigen::SelfAdjointEigenSolver<Matrix6d> eig(c);
  Eigen::Matrix<double, 6, 1> values = eig.eigenvalues().cwiseMax(1e-12);
  return eig.eigenvectors() * values.asDiagonal() * eig.eigenvectors().transpose();
}

// The positive semi-definite part of a symmetric matrix (negative eigenvalues set to zero).
Matrix6d positivePart(const Matrix6d& m) {
  Eigen::SelfAdjointEigenSolver<Matrix6d> eig(0.5 * (m + m.transpose()));
  const Eigen::Matrix<double, 6, 1> values = eig.eigenvalues().cwiseMax(0.0);
  return eig.eigenvectors() * values.asDiagonal() * eig.eigenvectors().transpose();
}

// The diagonal (t2, t2, t2, r2, r2, r2): one variance for the three translations and one for the
// three rotations (translation first, as se3Log).
Vector6d translationRotationDiagonal(double t2, double r2) { return (Vector6d() << t2, t2, t2, r2, r2, r2).finished(); }

Matrix6d inverseOf(const Matrix6d& covariance) {
  Eigen::SelfAdjointEigenSolver<Matrix6d> eig(0.5 * (covariance + covariance.transpose()));
  Eigen::Matrix<double, 6, 1> values = eig.eigenvalues().cwiseMax(1e-12);
  return eig.eigenvectors() * values.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
}

// Loop closure when tracking is frame to frame (the paper's set-up), measured on naraha
// (docs/pose_graph.md, docs/properties.md):
// - scan-to-scan verification: a submap placed with frame-to-frame increments is blurred by their
//   local drift (seed 1 icp+pgo 0.142 → 0.161 m against submaps);
// - no misfit term in the loop covariance: scan-to-scan loops are already timid (NEES 0.5) and
//   correct a drifting chain (seed 1 property-icp+pgo 0.1135 → 0.1335 m with it);
// - camera-label loops at the matched stretch's own keyframe, not the one nearest the query
//   (the nearest-keyframe loops made the maps worse on all eight seeds).
void forFrameToFrame(LoopClosureConfig& loop_config) {
  loop_config.submap_keyframes = 0;
  loop_config.verification.misfit_scale = 0.0;
  loop_config.partial_nearest_keyframe = false;
}

}  // namespace

Matrix6d WheelOdometryNoise::information() const {
  Vector6d sigma;
  sigma << translation_sigma, translation_sigma, vertical_sigma, tilt_sigma, tilt_sigma, yaw_sigma;
  return sigma.cwiseProduct(sigma).cwiseInverse().asDiagonal();
}

SlamConfig SlamConfig::forMethod(SlamMethod method) {
  SlamConfig c;
  c.method = method;
  c.odometry.registration.use_classes = usesClasses(method);
  c.loop_closure.verification.registration.use_classes = usesClasses(method);
  c.loop_closure.method =
      usesClasses(method) ? CandidateMethod::Constellation : CandidateMethod::Distance;
  return c;
}

TrackingCounts countTracking(const std::vector<FrameRecord>& frames) {
  TrackingCounts c;
  for (const auto& f : frames) {
    c.relocalised += f.status == FrameStatus::Relocalised;
    c.fallback += f.status == FrameStatus::Fallback;
  }
  c.tracked = frames.size() - c.relocalised - c.fallback;
  return c;
}

double SlamResult::framesPerSecond() const {
  return timings.total_s > 0 ? static_cast<double>(frames.size()) / timings.total_s : 0.0;
}

namespace {

// One SLAM run, frame by frame: each public step is one box of the paper's Fig. 1.
class SlamRun {
 public:
  SlamRun(ScanSource& source, const SlamConfig& config)
      : source_(source), config_(config), deskewer_(config.deskew) {
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
    if (!pgo_ || !isKeyframe(pose)) return;
    addGravityPrior(scan);
    if (loopsBesideTracking())
      pending_loops_.emplace(PendingLoops{pose, std::move(scan.cloud)});
    else
      closeLoops(pose, std::move(scan.cloud));
  }

  std::size_t frames() const { return result_.frames.size(); }

  SlamResult finish() {
    runPendingLoops();
    result_.source = source_.describe();  // after the scans: a decoder knows its sensor by then
    result_.tracked = trajectoryOf(tracked_);
    if (pgo_) {
      result_.keyframes = keyframe_frames_.size();
      optimiseWithLoops();
      refreshAnchorInformation();  // the graph written out carries what the last solve used
      const auto consistent = loops_->consistentLoops(keyframeEstimate());
      setLoopEdges(consistent);
      if (consistent.empty() && gravityAloneHelps()) optimise();
      for (const auto& l : loops_->acceptedLoops()) {
        const bool kept = std::any_of(consistent.begin(), consistent.end(),
                                      [&](const LoopClosure& c) { return c.from == l.from && c.to == l.to; });
        if (kept)
          result_.loops.push_back({keyframe_frames_[l.from], keyframe_frames_[l.to], toString(l.source), l.fitness, l.rmse});
        else
          reject(l, LoopRejection::Inconsistent, "not in the largest pairwise-consistent set");
      }
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
    pgo_ = usesPoseGraph(config_.method);
    if (!pgo_) return;
    LoopClosureConfig loop_config = config_.loop_closure;
    if (config_.odometry.mode != OdometryMode::FrameToMap) forFrameToFrame(loop_config);
    loops_ = std::make_unique<LoopDetector>(classes_, loop_config);
    if (config_.innovation_gate)
      loops_->setRelativeCovariance([this](std::size_t from, std::size_t to) { return relativeCovariance(from, to); });
    // Old keyframes are re-read when a loop needs them (bounded memory): from the recording when
    // it allows that, else from the copies a stream's keyframes leave on disk.
    if (source_.canReread()) {
      loops_->setCloudLoader([this](std::size_t k) {
        const std::size_t f = keyframe_frames_.at(k);
        LabeledCloud cloud = source_.reread(f);
        redoDeskew(cloud, result_.frames.at(f));
        return cloud;
      });
    } else {
      spill_.emplace();
      loops_->setCloudLoader(
          [this](std::size_t k) { return spill_->load(keyframe_frames_.at(k), source_.classTable()); });
    }
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
    FrameRecord rec;
    rec.index = frames();
    rec.stamp = scan.stamp;
    if (!usesIcp(config_.method)) {
      if (wheel_increment) rec.T_prev_curr = *wheel_increment;
      return rec;
    }
    rec.deskew_velocity = deskewer_.apply(scan.cloud, scan.stamp, wheel_increment);
    const OdometryFrame& f = tracker_->addFrame(scan.cloud, wheel_increment, scan.stamp);
    deskewer_.tracked(f.increment);
    rec.T_prev_curr = f.increment;
    rec.covariance = f.covariance;
    rec.icp_used = f.status != FrameStatus::Fallback;
    rec.status = f.status;
    rec.fallback_reason = f.reason;
    rec.fitness = f.registration.fitness;
    rec.rmse = f.registration.inlier_rmse;
    rec.iterations = f.registration.iterations;
    rec.stalled = (f.status == FrameStatus::Tracked || f.status == FrameStatus::Degenerate) &&
                  !f.registration.converged && f.registration.termination == Termination::MaxIterations;
    rec.points = f.source_points;
    rec.guess_covariance = guessCovariance(f);
    return rec;
  }

  /// FrameRecord::guess_covariance. Frame to map registers in the world frame, so the
  /// registration's own covariance maps to the increment's frame by Ad(T_world_prev⁻¹).
  Matrix6d guessCovariance(const OdometryFrame& f) const {
    if (f.status == FrameStatus::Fallback) return f.covariance;
    if (f.status != FrameStatus::Degenerate || config_.odometry.mode != OdometryMode::FrameToMap) return Matrix6d::Zero();
    const Matrix6d Ad = adjoint((f.pose * f.increment.inverse()).inverse());
    return positivePart(f.covariance - Ad * f.registration.covariance * Ad.transpose());
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
  void addOdometryEdge(FrameRecord& rec) {
    if (rec.index == 0) {
      step_covariance_.push_back(Matrix6d::Zero());
      guess_step_covariance_.push_back(Matrix6d::Zero());
      return;
    }
    const EdgeNoise noise = odometryEdgeNoise(rec);
    const Matrix6d& cov = noise.covariance;
    step_covariance_.push_back(cov);
    guess_step_covariance_.push_back(rec.icp_used ? rec.guess_covariance : cov);
    result_.graph.addEdge(static_cast<int>(rec.index - 1), static_cast<int>(rec.index), rec.T_prev_curr,
                          noise.information, EdgeKind::Odometry);
  }

  /// Issue 19 (odometry.reestimate_lost_frames): once a frame is verified again the tracker
  /// re-estimates the lost frames before it and the increments on both sides; those replace the
  /// recorded ones (record, odometry edge, tracked pose and graph node from the first changed frame
  /// on), as `hazmap odometry` writes them. Only with relocalise_suspect (the worst-day set-up):
  /// a normal run's graph stays bit for bit.
  void takeReestimatedLostFrames() {
    if (!tracker_ || !usesIcp(config_.method) || !config_.odometry.relocalise_suspect ||
        !config_.odometry.reestimate_lost_frames)
      return;
    const std::vector<OdometryFrame>& tf = tracker_->frames();
    const std::size_t n = result_.frames.size(), back = static_cast<std::size_t>(config_.odometry.lost_frames_max) + 2;
    std::size_t first = n;
    for (std::size_t k = n > back ? n - back : 1; k < n && k < tf.size(); ++k) {
      FrameRecord& rec = result_.frames[k];
      const OdometryFrame& f = tf[k];
      if (f.increment.matrix() == rec.T_prev_curr.matrix() && f.status == rec.status) continue;
      rec.T_prev_curr = f.increment;
      rec.covariance = f.covariance;
      rec.status = f.status;
      rec.icp_used = f.status != FrameStatus::Fallback;
      rec.fallback_reason = f.reason;
      const EdgeNoise noise = odometryEdgeNoise(rec);
      step_covariance_[k] = noise.covariance;
      for (PoseGraphEdge& e : result_.graph.edges)
        if (e.kind == EdgeKind::Odometry && e.from == static_cast<int>(k - 1) && e.to == static_cast<int>(k)) {
          e.T_from_to = rec.T_prev_curr;
          e.information = noise.information;
        }
      first = std::min(first, k);
    }
    for (std::size_t k = first; k < n; ++k) {
      tracked_[k] = normalized(tracked_[k - 1] * result_.frames[k].T_prev_curr);
      result_.graph.poses[k] = normalized(result_.graph.poses[k - 1] * result_.frames[k].T_prev_curr);
    }
  }

  /// An odometry edge's noise: the covariance the loop gate chains (the registration's, below, or
  /// the wheels' when the tracker fell back to the encoders) and the information the graph gets.
  struct EdgeNoise {
    Matrix6d covariance, information;
  };
  EdgeNoise odometryEdgeNoise(const FrameRecord& rec) const {
    if (!rec.icp_used) return {inverseOf(config_.wheel_noise.information()), config_.wheel_noise.information()};
    const Matrix6d cov = registrationEdgeCovariance(rec);
    return {cov, inverseOf(cov)};
  }

  /// The floored Σ_ICP: the registration's covariance, which the loop gate's chain and the map
  /// anchors use.
  Matrix6d registrationEdgeCovariance(const FrameRecord& rec) const {
    return flooredCovariance(rec.covariance, config_.min_translation_sigma, config_.min_rotation_sigma);
  }

  /// Whether a run that closed no loop is optimised with its gravity priors alone
  /// (PoseGraphConfig::gravity_alone_frame_to_map).
  bool gravityAloneHelps() const {
    if (result_.graph.gravity_priors.empty()) return false;
    return config_.odometry.mode != OdometryMode::FrameToMap || config_.graph.gravity_alone_frame_to_map;
  }

  /// The new keyframe's gravity-direction prior (PoseGraphConfig::gravity_prior) when its scan
  /// has an IMU measurement: roll and pitch observed absolutely, also where no loop reaches.
  void addGravityPrior(const Scan& scan) {
    if (!config_.graph.gravity_prior || !scan.gravity) return;
    double sigma = config_.graph.gravity_sigma_deg > 0.0 ? config_.graph.gravity_sigma_deg * M_PI / 180.0
                                                        : scan.gravity->sigmaRad();
    if (config_.odometry.mode == OdometryMode::FrameToMap) sigma *= config_.graph.gravity_sigma_scale_frame_to_map;
    result_.graph.addGravityPrior(static_cast<int>(frames() - 1), scan.gravity->down, sigma);
  }

  /// Online cost (SlamConfig::loops_beside_tracking): a keyframe's loop stage runs while the
  /// next scan is tracked. The tracker reads nothing the loop stage writes (graph, keyframes,
  /// loops) and the loop stage nothing the tracker writes, and the next scan's node and edges
  /// join the graph only after both finished, so the results are the same bit for bit.
  bool loopsBesideTracking() const { return config_.loops_beside_tracking; }

  /// track(), with the previous keyframe's pending loop stage (if any) running beside it.
  FrameRecord trackBesideLoops(Scan& scan, const std::optional<Eigen::Isometry3d>& wheel_increment) {
    FrameRecord record;
    const auto tracking = [&] {
      const auto t_frame = Clock::now();
      record = track(scan, wheel_increment);
      record.milliseconds = 1e3 * secondsSince(t_frame);
      result_.timings.tracking_s += secondsSince(t_frame);
    };
    if (pending_loops_)
      tbb::parallel_invoke(tracking, [&] { runPendingLoops(); });
    else
      tracking();
    return record;
  }

  void runPendingLoops() {
    if (!pending_loops_) return;
    PendingLoops p = std::move(*pending_loops_);
    pending_loops_.reset();
    closeLoops(p.pose, std::move(p.cloud));
  }

  bool isKeyframe(const Eigen::Isometry3d& pose) const {
    if (keyframe_frames_.empty()) return true;
    const Eigen::Isometry3d since = last_keyframe_pose_.inverse() * pose;
    return translationNorm(since) >= config_.keyframe_distance ||
           rotationAngle(since) >= config_.keyframe_angle;
  }

  /// Property-landmark (or distance) loop candidates, verified by ICP; online re-optimisation
  /// as soon as one is accepted.
  void closeLoops(const Eigen::Isometry3d& pose, LabeledCloud cloud) {
    const auto t_loop = Clock::now();
    last_keyframe_pose_ = pose;
    keyframe_frames_.push_back(frames() - 1);
    if (spill_) spill_->store(keyframe_frames_.back(), cloud);
    const std::size_t k = loops_->addKeyframe(std::move(cloud));
    addAnchorEdge();
    if (!schedule_.searches(k)) return void(result_.timings.loop_s += secondsSince(t_loop));
    ++result_.keyframes_searched;
    const LoopDetection detection = loops_->detect(k, keyframeEstimate());
    if (!detection.accepted.empty()) schedule_.accepted(k);
    result_.loop_candidates += detection.candidates.size();
    result_.loop_near_duplicates += detection.near_duplicates;
    result_.loop_light_verifications += detection.light_verifications;
    result_.submap_targets_built = loops_->submapTargetsBuilt();
    for (const auto& v : detection.verifications) {
      result_.loops_verified += v.accepted ? 1 : 0;
      if (!v.accepted) reject(v.closure, v.rejection, v.reason);
    }
    result_.timings.loop_s += secondsSince(t_loop);
    if (!detection.accepted.empty() && config_.optimise_online) optimiseWithLoops();
  }

  /// The covariance the graph's odometry chain gives the relative pose of two keyframes. (Using
  /// the map anchor's covariance instead when one links them was measured worse: corridor seed 1
  /// 0.129 → 0.142 m, docs/pose_graph.md.)
  Matrix6d relativeCovariance(std::size_t from, std::size_t to) const {
    return chainCovariance(result_.graph.poses, step_covariance_, keyframe_frames_.at(from), keyframe_frames_.at(to));
  }

  Matrix6d anchorCovariance(std::size_t frame) const {
    Matrix6d cov = registrationEdgeCovariance(result_.frames[frame]);
    const double t2 = config_.anchor_sigma_translation * config_.anchor_sigma_translation;
    const double r2 = config_.anchor_sigma_rotation * config_.anchor_sigma_rotation;
    cov.diagonal() += translationRotationDiagonal(t2, r2);
    return cov;
  }

  /// The map-anchor edge of the newest keyframe (SlamConfig::anchor_radius). Its covariance also
  /// carries, as a shared part, the chained covariance of every increment's share that no
  /// registration vouched for (FrameRecord::guess_covariance: a fallback's whole covariance, a
  /// degenerate frame's along the directions where the guess was kept): there the tracker
  /// dead-reckoned, so its map places the newer keyframe relative to the older one no better than
  /// the chained guesses (tanks seed 8: anchors 25-42 cm and 20-38 mrad off, claiming 2-3 cm,
  /// turned the whole route 5 deg; docs/pose_graph.md).
  void addAnchorEdge() {
    if (config_.odometry.mode != OdometryMode::FrameToMap || config_.anchor_radius <= 0.0) return;
    const std::size_t n = keyframe_frames_.size(), gap = config_.loop_closure.candidates.min_index_gap;
    const std::size_t j = keyframe_frames_.back();
    std::optional<std::size_t> best;
    double best_d = config_.anchor_radius;
    for (std::size_t k = 0; k + gap < n; ++k) {
      const double d = (tracked_.at(keyframe_frames_[k]).translation() - tracked_.at(j).translation()).norm();
      if (d <= best_d) best_d = d, best = keyframe_frames_[k];
    }
    if (!best) return;
    AnchorCovariance a{*best, j, anchorCovariance(j), Matrix6d::Zero()};
    a.shared = chainCovariance(result_.graph.poses, guess_step_covariance_, *best, j);
    anchor_covariances_.push_back(a);
    result_.graph.addEdge(static_cast<int>(*best), static_cast<int>(j), normalized(tracked_.at(*best).inverse() * tracked_.at(j)),
                          inverseOf(a.own + a.shared), EdgeKind::MapAnchor);
    result_.anchors.push_back({*best, j});
  }

  /// The anchors' dead-reckoned parts are one error shared by every anchor whose span covers the
  /// same steps (the tracker's map placed the whole return path with the same drift), not
  /// independent ones: counted as independent, n anchors across one stretch claimed √n times
  /// what they knew (corridor seed 3: 20-odd anchors held the return 30-90 cm off along the axis
  /// against the loops). So each anchor's shared part is multiplied by the number of anchors
  /// whose spans overlap its own (itself included): together they then claim the drift once, as
  /// covariance intersection does for estimates of unknown correlation. Refreshed before every
  /// optimisation, since later anchors join the overlap.
  void refreshAnchorInformation() {
    if (anchor_covariances_.empty()) return;
    std::map<std::pair<int, int>, Matrix6d> information;
    for (const AnchorCovariance& a : anchor_covariances_) {
      const auto overlapping = std::count_if(anchor_covariances_.begin(), anchor_covariances_.end(), [&](const AnchorCovariance& b) {
        return b.from < a.to && a.from < b.to;
      });
      information[{static_cast<int>(a.from), static_cast<int>(a.to)}] =
          inverseOf(a.own + static_cast<double>(overlapping) * a.shared);
    }
    for (PoseGraphEdge& e : result_.graph.edges)
      if (e.kind == EdgeKind::MapAnchor)
        if (const auto it = information.find({e.from, e.to}); it != information.end()) e.information = it->second;
  }

  void reject(const LoopClosure& l, LoopRejection why, std::string detail) {
    result_.rejected_loops.push_back({keyframe_frames_.at(l.from), keyframe_frames_.at(l.to), why, std::move(detail)});
  }

  /// The pairwise-consistent loops into the graph and one optimisation; a loop the solution
  /// cannot agree with (its whitened residual beyond the gate's χ² quantile) or a failed solve
  /// is dropped, recorded, and the previous estimate kept (then re-solved without the loop).
  void optimiseWithLoops() {
    for (int attempt = 0; attempt < 3; ++attempt) {
      const std::vector<LoopClosure> consistent = loops_->consistentLoops(keyframeEstimate());
      if (consistent.empty()) return;
      setLoopEdges(consistent);
      const std::vector<Eigen::Isometry3d> before = result_.graph.poses;
      const std::string failure = optimise();
      if (failure.empty()) {
        const std::vector<LoopClosure> misfits = loopsTheSolutionRejects(consistent);
        if (misfits.empty()) return;
        result_.optimisation_outcomes.back() = {false, "dropped " + std::to_string(misfits.size()) +
                                                          " loop(s) the solution could not agree with"};
        for (const auto& l : misfits) dropLoop(l, LoopRejection::OptimisationDiverged, "residual beyond the χ² gate after optimisation");
      } else {
        for (const auto& l : consistent)
          if (l.to == consistent.back().to) dropLoop(l, LoopRejection::OptimisationFailed, failure);
      }
      result_.graph.poses = before;
    }
  }

  void dropLoop(const LoopClosure& l, LoopRejection why, const std::string& detail) {
    loops_->dropLoop(l.from, l.to);
    reject(l, why, detail);
  }

  /// Loops whose residual in the solution exceeds the gate's χ² quantile.
  std::vector<LoopClosure> loopsTheSolutionRejects(const std::vector<LoopClosure>& loops) const {
    const double threshold = chiSquareQuantile(6, config_.loop_closure.consistency.gate_probability);
    std::vector<LoopClosure> out;
    for (std::size_t i : edgesBeyond(result_.graph, EdgeKind::Loop, threshold)) {
      const PoseGraphEdge& e = result_.graph.edges[i];
      for (const auto& l : loops)
        if (keyframe_frames_[l.from] == static_cast<std::size_t>(e.from) && keyframe_frames_[l.to] == static_cast<std::size_t>(e.to)) {
          out.push_back(l);
          break;
        }
    }
    return out;
  }

  /// Replaces the graph's loop edges by the pairwise-consistent set.
  void setLoopEdges(const std::vector<LoopClosure>& consistent) {
    PoseGraph& graph = result_.graph;
    std::erase_if(graph.edges, [](const PoseGraphEdge& e) { return e.kind == EdgeKind::Loop; });
    for (const auto& l : consistent)
      graph.addEdge(static_cast<int>(keyframe_frames_[l.from]), static_cast<int>(keyframe_frames_[l.to]), l.T_from_to,
                    l.information, EdgeKind::Loop);
  }

  PoseList keyframeEstimate() const {
    PoseList poses;
    for (std::size_t f : keyframe_frames_) poses.push_back(result_.graph.poses[f]);
    return poses;
  }

  /// One optimisation; on failure (Ceres cannot solve it, non-finite or higher cost) the poses
  /// are restored and the reason returned.
  std::string optimise() {
    refreshAnchorInformation();
    const auto t = Clock::now();
    std::string failure;
    result_.optimisations.push_back(optimizePoseGraphOrKeep(result_.graph, config_.graph, failure));
    result_.optimisation_outcomes.push_back({failure.empty(), failure.empty() ? "" : "not solved, previous estimate kept: " + failure});
    result_.timings.graph_s += secondsSince(t);
    return failure;
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
  std::optional<Odometry> tracker_;
  std::vector<Eigen::Isometry3d> tracked_;
  bool pgo_ = false;
  std::unique_ptr<LoopDetector> loops_;
  LoopSchedule schedule_{config_.loop_search_every, config_.loop_pause_after_accept};
  struct PendingLoops {
    Eigen::Isometry3d pose;
    LabeledCloud cloud;
  };
  std::optional<PendingLoops> pending_loops_;  // the newest keyframe's loop stage, not yet run
  std::optional<KeyframeSpill> spill_;
  std::vector<std::size_t> keyframe_frames_;  // keyframe index → frame index
  std::vector<Matrix6d> step_covariance_;      // frame index → its odometry edge's covariance
  Eigen::Isometry3d last_keyframe_pose_ = Eigen::Isometry3d::Identity();
  std::vector<Matrix6d> guess_step_covariance_;       // frame index → FrameRecord::guess_covariance
  struct AnchorCovariance {
    std::size_t from, to;  // frames
    Matrix6d own;          // the registration's and the anchor's own (anchorCovariance)
    Matrix6d shared;       // the chained dead-reckoned steps it spans (guess_step_covariance_)
  };
  std::vector<AnchorCovariance> anchor_covariances_;
};

}  // namespace

void redoDeskew(LabeledCloud& cloud, const FrameRecord& record) {
  if (record.deskew_velocity) deskewScan(cloud, *record.deskew_velocity, record.stamp);
}

SlamResult runSlam(ScanSource& source, const SlamConfig& config, const FrameProgress& progress) {
  config.validate();
  std::optional<tbb::global_control> threads;
  if (config.threads > 0)
    threads.emplace(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(config.threads));
  const auto t_start = Clock::now();
  SlamRun run(source, config);
  const std::size_t total = source.size().value_or(0);
  while (std::optional<Scan> scan = source.next()) {
    run.addScan(std::move(*scan));
    if (progress) progress(run.frames(), total);
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
