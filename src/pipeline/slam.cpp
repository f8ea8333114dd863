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
#include "hazmap/pipeline/map_entropy.hpp"
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

// The planar components of an se(3) vector (translation first): x, y, yaw.
constexpr int kPlanar[3] = {0, 1, 5};

Eigen::Vector3d planarPart(const Vector6d& v) { return {v(kPlanar[0]), v(kPlanar[1]), v(kPlanar[2])}; }

Eigen::Matrix3d planarBlock(const Matrix6d& m) {
  Eigen::Matrix3d b;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) b(r, c) = m(kPlanar[r], kPlanar[c]);
  return b;
}

Matrix6d embedPlanar(const Eigen::Matrix3d& b) {
  Matrix6d m = Matrix6d::Zero();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(kPlanar[r], kPlanar[c]) = b(r, c);
  return m;
}

// The diagonal (t2, t2, t2, r2, r2, r2): one variance for the three translations and one for the
// three rotations (translation first, as se3Log).
Vector6d translationRotationDiagonal(double t2, double r2) { return (Vector6d() << t2, t2, t2, r2, r2, r2).finished(); }

Matrix6d inverseOf(const Matrix6d& covariance) {
  Eigen::SelfAdjointEigenSolver<Matrix6d> eig(0.5 * (covariance + covariance.transpose()));
  Eigen::Matrix<double, 6, 1> values = eig.eigenvalues().cwiseMax(1e-12);
  return eig.eigenvectors() * values.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
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
      finalAcceptTest(consistent);
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
    if (config_.submaps_only_frame_to_map && config_.odometry.mode != OdometryMode::FrameToMap)
      loop_config.submap_keyframes = 0;
    if (config_.misfit_only_frame_to_map && config_.odometry.mode != OdometryMode::FrameToMap)
      loop_config.verification.misfit_scale = 0.0;
    if (config_.nearest_partial_loops_only_frame_to_map && config_.odometry.mode != OdometryMode::FrameToMap)
      loop_config.partial_nearest_keyframe = false;
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
    rec.wheel_increment = wheel_increment;
    rec.label_only_directions = labelOnlyDirections(f);
    return rec;
  }

  /// FrameRecord::label_only_directions (frame to map: world-frame directions to the increment's).
  Matrix6d labelOnlyDirections(const OdometryFrame& f) const {
    Matrix6d sum = Matrix6d::Zero();
    if (f.status == FrameStatus::Fallback || config_.odometry.mode != OdometryMode::FrameToMap) return sum;
    for (const Vector6d& u : f.registration.label_only_directions) sum += u * u.transpose();
    const Matrix6d Ad = adjoint((f.pose * f.increment.inverse()).inverse());
    return Ad * sum * Ad.transpose();
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
      unverified_step_covariance_.push_back(Matrix6d::Zero());
      guess_step_covariance_.push_back(Matrix6d::Zero());
      return;
    }
    const EdgeNoise noise = odometryEdgeNoise(rec);
    const Matrix6d& cov = noise.covariance;
    step_covariance_.push_back(cov);
    unverified_step_covariance_.push_back(rec.icp_used ? Matrix6d::Zero() : cov);
    guess_step_covariance_.push_back(rec.icp_used ? Matrix6d(rec.guess_covariance + config_.label_only_sigma *
                                                                config_.label_only_sigma * rec.label_only_directions)
                                                  : cov);
    const int e = result_.graph.addEdge(static_cast<int>(rec.index - 1), static_cast<int>(rec.index), rec.T_prev_curr,
                                        noise.information, EdgeKind::Odometry);
    noise.applyTo(result_.graph.edges[static_cast<std::size_t>(e)]);
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
      unverified_step_covariance_[k] = rec.icp_used ? Matrix6d::Zero() : noise.covariance;
      for (PoseGraphEdge& e : result_.graph.edges)
        if (e.kind == EdgeKind::Odometry && e.from == static_cast<int>(k - 1) && e.to == static_cast<int>(k)) {
          e.T_from_to = rec.T_prev_curr;
          noise.applyTo(e);
        }
      first = std::min(first, k);
    }
    for (std::size_t k = first; k < n; ++k) {
      tracked_[k] = normalized(tracked_[k - 1] * result_.frames[k].T_prev_curr);
      result_.graph.poses[k] = normalized(result_.graph.poses[k - 1] * result_.frames[k].T_prev_curr);
    }
  }

  /// An odometry edge's noise: the covariance the loop gate chains (the registration's, below, or
  /// the wheels' when the tracker fell back to the encoders) and the information the graph gets —
  /// its inverse, or the honest model's (SlamConfig::honest_odometry_edges, frame to map). Sets
  /// rec.edge_doubt.
  struct EdgeNoise {
    Matrix6d covariance, information;
    Matrix6d alt_information = Matrix6d::Zero();  ///< SlamConfig::odometry_edge_mixture: the wide component
    double alt_weight = 0.0;                      ///< its prior probability (0 = one Gaussian)
    /// The edge's information and, for a mixture, its wide component: one place for both sites
    /// that write an odometry edge (addOdometryEdge, takeReestimatedLostFrames).
    void applyTo(PoseGraphEdge& edge) const {
      edge.information = information;
      edge.alt_information = alt_information;
      edge.alt_weight = alt_weight;
    }
  };
  EdgeNoise odometryEdgeNoise(FrameRecord& rec) const {
    rec.edge_doubt.clear();
    if (!rec.icp_used || (rec.stalled && config_.stalled_edges_use_wheel_noise))
      return {inverseOf(config_.wheel_noise.information()), config_.wheel_noise.information()};
    const Matrix6d cov = registrationEdgeCovariance(rec);
    const bool honest = config_.honest_odometry_edges && config_.odometry.mode == OdometryMode::FrameToMap;
    if (!honest) return {cov, inverseOf(cov)};
    const Matrix6d tight = honestTightCovariance(rec);
    Matrix6d wide = tight;
    addWrongBasinTerms(rec, wide);
    if (!config_.odometry_edge_mixture || rec.edge_doubt.empty()) return {cov, inverseOf(wide)};
    // A doubtful increment is right (tight) or in a wrong basin (wide), not anything between.
    return {cov, inverseOf(tight), inverseOf(wide), config_.odometry_mixture_weight};
  }

  /// SlamConfig::honest_odometry_edges: the increment's error model without the wrong-basin terms
  /// (floor, turn, label-only directions).
  Matrix6d honestTightCovariance(const FrameRecord& rec) const {
    Matrix6d cov = config_.odometry_covariance_scale * positivePart(rec.covariance);
    const double t2 = config_.odometry_floor_translation * config_.odometry_floor_translation;
    const double r2 = config_.odometry_floor_rotation * config_.odometry_floor_rotation;
    cov.diagonal() += translationRotationDiagonal(t2, r2);
    const double turn = std::abs(se3Log(rec.T_prev_curr)(5));
    const double tt = config_.odometry_turn_translation * turn, tr = config_.odometry_turn_rotation * turn;
    cov.diagonal() += (Vector6d() << tt * tt, tt * tt, 0.0, 0.0, 0.0, tr * tr).finished();
    cov += config_.label_only_sigma * config_.label_only_sigma * rec.label_only_directions;
    return cov;
  }

  /// SlamConfig::honest_odometry_edges: a motion prior that contradicts the increment beyond the
  /// χ²(3) bound (x, y, yaw; the wheels see nothing else) means the increment may be wrong by as
  /// much as the disagreement δ: δδᵀ is added (and the wheels' nominal noise, since either may be
  /// the one that is right). Wheels first, then constant velocity against the updated covariance.
  void addWrongBasinTerms(FrameRecord& rec, Matrix6d& cov) const {
    rec.edge_doubt.clear();
    const double bound = chiSquareQuantile(3, config_.odometry_gate_probability);
    const Vector6d step = se3Log(rec.T_prev_curr);
    const auto contradicts = [&](const Eigen::Vector3d& d, const Eigen::Matrix3d& prior) {
      const Eigen::Matrix3d s = planarBlock(cov) + prior;
      return d.dot(s.ldlt().solve(d)) > bound;
    };
    const auto note = [&](const char* why) { rec.edge_doubt += (rec.edge_doubt.empty() ? "" : "+") + std::string(why); };
    if (rec.wheel_increment) {
      const double forward = config_.wheel_gate_forward_fraction * step.head<2>().norm() + config_.wheel_gate_forward_sigma;
      const double yaw = config_.wheel_gate_yaw_sigma + config_.wheel_gate_turn_fraction * std::abs(step(5));
      const Eigen::Matrix3d W = Eigen::Vector3d(forward * forward, config_.wheel_gate_lateral_sigma * config_.wheel_gate_lateral_sigma,
                                                yaw * yaw).asDiagonal();
      const Eigen::Vector3d d = planarPart(se3Log(*rec.wheel_increment * rec.T_prev_curr.inverse()));
      if (contradicts(d, W)) {
        cov += embedPlanar(W + d * d.transpose());
        note("wheel");
      }
    }
    if (rec.index >= 2) {
      const double t = config_.velocity_gate_translation_sigma, r = config_.velocity_gate_rotation_sigma;
      const Eigen::Matrix3d V = Eigen::Vector3d(t * t, t * t, r * r).asDiagonal();
      const Eigen::Vector3d d =
          planarPart(se3Log(result_.frames[rec.index - 1].T_prev_curr * rec.T_prev_curr.inverse()));
      if (contradicts(d, V)) {
        cov += embedPlanar(d * d.transpose());
        note("velocity");
      }
    }
  }

  /// scale · floored Σ_ICP + (weight · departure from constant velocity)² (SlamConfig): the
  /// registration's covariance, which the loop gate's chain and the map anchors use.
  Matrix6d registrationEdgeCovariance(const FrameRecord& rec) const {
    Matrix6d cov = config_.odometry_covariance_scale * floored(rec.covariance);
    cov += config_.label_only_sigma * config_.label_only_sigma * rec.label_only_directions;
    if (config_.motion_disagreement_weight > 0.0 && rec.index >= 2) {
      const Vector6d d = se3Log(result_.frames[rec.index - 1].T_prev_curr.inverse() * rec.T_prev_curr);
      const double w = config_.motion_disagreement_weight;
      const double t2 = w * w * d.head<3>().squaredNorm(), r2 = w * w * d.tail<3>().squaredNorm();
      cov.diagonal() += translationRotationDiagonal(t2, r2);
    }
    return cov;
  }

  Matrix6d floored(const Matrix6d& covariance) const {
    if (!config_.additive_floor)
      return flooredCovariance(covariance, config_.min_translation_sigma, config_.min_rotation_sigma);
    const double t2 = config_.min_translation_sigma * config_.min_translation_sigma;
    const double r2 = config_.min_rotation_sigma * config_.min_rotation_sigma;
    return positivePart(covariance) + Matrix6d(translationRotationDiagonal(t2, r2).asDiagonal());
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
  /// join the graph only after both finished, so the results are the same bit for bit. Not when
  /// an optimisation re-anchors the tracker's map (reanchor_map): then tracking waits for it.
  bool loopsBesideTracking() const { return config_.loops_beside_tracking && !config_.reanchor_map; }

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

  /// The map-anchor edge of the newest keyframe (SlamConfig::anchor_radius). Across frames no
  /// registration vouches for (fallback or stalled), the tracker placed their points in its map
  /// on an unverified increment, so the map the later frames registered against may contradict
  /// the earlier one by as much as those increments are uncertain: their chained covariance is
  /// added (naraha seed 7: two wheel slips at frames 31–32 left the rest 1.05 m off, and anchors
  /// with 2 cm σ across them held the graph there against every loop).
  void addAnchorEdge() {
    if (config_.odometry.mode != OdometryMode::FrameToMap || config_.anchor_radius <= 0.0) return;
    const std::size_t n = keyframe_frames_.size(), gap = config_.loop_closure.candidates.min_index_gap;
    const std::size_t j = keyframe_frames_.back();
    std::optional<std::size_t> best;
    double best_d = config_.anchor_radius;
    for (std::size_t k = 0; k + gap < n; ++k) {
      const double d = (mapPose(keyframe_frames_[k]).translation() - mapPose(j).translation()).norm();
      if (d <= best_d) best_d = d, best = keyframe_frames_[k];
    }
    if (!best) return;
    AnchorCovariance a{*best, j, anchorCovariance(j), Matrix6d::Zero()};
    if (config_.anchors_carry_guess_directions)
      a.shared = chainCovariance(result_.graph.poses, guess_step_covariance_, *best, j);
    else if (config_.anchors_carry_unverified_steps)
      a.own += chainCovariance(result_.graph.poses, unverified_step_covariance_, *best, j);
    anchor_covariances_.push_back(a);
    result_.graph.addEdge(static_cast<int>(*best), static_cast<int>(j), normalized(mapPose(*best).inverse() * mapPose(j)),
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
  /// optimisation, since later anchors join the overlap (SlamConfig::anchors_share_drift).
  void refreshAnchorInformation() {
    if (!config_.anchors_share_drift || anchor_covariances_.empty()) return;
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
        if (misfits.empty()) return reanchorTracking(before);
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

  /// The final accept test (SlamConfig::final_accept_test): the optimised trajectory stays only
  /// when the keyframes' map it places is at least as crisp (mean map entropy) as tracking's.
  void finalAcceptTest(const std::vector<LoopClosure>& loops) {
    if (!config_.final_accept_test || loops.empty()) return;
    FinalAcceptTest& t = result_.final_accept;
    t.tested = true;
    // Tracking is a hypothesis only when the verified loops do not contradict it.
    PoseList tracked_keyframes;
    for (std::size_t f : keyframe_frames_) tracked_keyframes.push_back(tracked_[f]);
    for (const auto& l : loops) {
      const GateResult g = innovationGate(l, tracked_keyframes, Matrix6d::Zero(),
                                          config_.loop_closure.consistency.gate_probability);
      t.worst_loop_d2 = std::max(t.worst_loop_d2, g.mahalanobis2);
      t.loops_contradict_tracking = t.loops_contradict_tracking || !g.accepted;
    }
    if (t.loops_contradict_tracking) return;
    std::vector<std::shared_ptr<const LabeledCloud>> clouds;
    std::vector<Eigen::Isometry3d> optimised, tracking;
    for (std::size_t k = 0; k < keyframe_frames_.size(); ++k) {
      clouds.push_back(loops_->cloud(k));
      optimised.push_back(result_.graph.poses[keyframe_frames_[k]]);
      tracking.push_back(tracked_[keyframe_frames_[k]]);
    }
    MapEntropyConfig mc;
    mc.radius = config_.map_entropy_radius;
    t.optimised_entropy = meanMapEntropy(clouds, optimised, mc);
    t.tracking_entropy = meanMapEntropy(clouds, tracking, mc);
    t.kept_optimised = !(t.optimised_entropy > t.tracking_entropy);
    if (!t.kept_optimised) result_.estimate = result_.tracked;
  }

  /// The map follows the graph (SlamConfig::reanchor_map): when the applied optimisation moved a
  /// frame by more than reanchor_min_shift, the tracker's local map and poses take the graph's.
  void reanchorTracking(const std::vector<Eigen::Isometry3d>& before) {
    if (!config_.reanchor_map || config_.odometry.mode != OdometryMode::FrameToMap || !usesIcp(config_.method)) return;
    const std::vector<Eigen::Isometry3d>& after = result_.graph.poses;
    double shift = 0.0;
    for (std::size_t i = 0; i < after.size(); ++i)
      shift = std::max(shift, (after[i].translation() - before[i].translation()).norm());
    if (shift <= config_.reanchor_min_shift) return;
    tracker_->reanchor(after);
    ++result_.reanchors;
  }

  /// Where the tracker's map holds frame f's points: its tracked pose, or the graph's pose of the
  /// last re-anchoring (and the increments since).
  const Eigen::Isometry3d& mapPose(std::size_t f) const {
    return config_.reanchor_map && tracker_ && usesIcp(config_.method) ? tracker_->frames()[f].pose : tracked_[f];
  }

  void dropLoop(const LoopClosure& l, LoopRejection why, const std::string& detail) {
    loops_->dropLoop(l.from, l.to);
    reject(l, why, detail);
  }

  /// Loops whose residual in the solution exceeds the gate's χ² quantile. With loop_bias the test
  /// is the loop's whole residual (bias included) against its marginal covariance, the one it
  /// claims (marginalInformation).
  std::vector<LoopClosure> loopsTheSolutionRejects(const std::vector<LoopClosure>& loops) const {
    const double threshold = chiSquareQuantile(6, config_.loop_closure.consistency.gate_probability);
    std::vector<LoopClosure> out;
    const auto closureOf = [&](const PoseGraphEdge& e) -> const LoopClosure* {
      for (const auto& l : loops)
        if (keyframe_frames_[l.from] == static_cast<std::size_t>(e.from) && keyframe_frames_[l.to] == static_cast<std::size_t>(e.to))
          return &l;
      return nullptr;
    };
    if (!config_.loop_bias) {
      for (std::size_t i : edgesBeyond(result_.graph, EdgeKind::Loop, threshold))
        if (const LoopClosure* l = closureOf(result_.graph.edges[i])) out.push_back(*l);
      return out;
    }
    for (const PoseGraphEdge& e : result_.graph.edges) {
      const LoopClosure* l = e.kind == EdgeKind::Loop ? closureOf(e) : nullptr;
      if (!l) continue;
      const Vector6d r = geodesicError(result_.graph, e);
      const Matrix6d info = informationLeftToRight(e.T_from_to, marginalInformation(result_.graph, e));
      if (!(r.dot(info * r) <= threshold)) out.push_back(*l);
    }
    return out;
  }

  /// Replaces the graph's loop edges by the pairwise-consistent set (and, with loop_bias, their
  /// bias nodes).
  void setLoopEdges(const std::vector<LoopClosure>& consistent) {
    PoseGraph& graph = result_.graph;
    std::erase_if(graph.edges, [](const PoseGraphEdge& e) { return e.kind == EdgeKind::Loop; });
    graph.biases.clear();
    const int first = graph.numEdges();
    for (const auto& l : consistent) {
      if (!config_.loop_bias) {
        graph.addEdge(static_cast<int>(keyframe_frames_[l.from]), static_cast<int>(keyframe_frames_[l.to]), l.T_from_to,
                      l.information, EdgeKind::Loop);
        continue;
      }
      const Matrix6d own = loopOwnCovariance(l);
      PoseGraphEdge& e = graph.edges[static_cast<std::size_t>(graph.addEdge(
          static_cast<int>(keyframe_frames_[l.from]), static_cast<int>(keyframe_frames_[l.to]), l.T_from_to, inverseOf(own),
          EdgeKind::Loop))];
      if (!(config_.loop_tail_weight > 0.0)) continue;
      const double t2 = config_.loop_tail_sigma_translation * config_.loop_tail_sigma_translation;
      const double r2 = config_.loop_tail_sigma_rotation * config_.loop_tail_sigma_rotation;
      e.alt_information = inverseOf(own + Matrix6d(translationRotationDiagonal(t2, r2).asDiagonal()));
      e.alt_weight = config_.loop_tail_weight;
    }
    if (config_.loop_bias) attachLoopBiases(consistent, first);
  }

  /// SlamConfig::loop_bias: a loop edge's own part — the verification covariance with
  /// loop_own_sigma_* in place of the verification floor.
  Matrix6d loopOwnCovariance(const LoopClosure& l) const {
    const auto sq = [](double s) { return s * s; };
    const double t2 = sq(config_.loop_own_sigma_translation), r2 = sq(config_.loop_own_sigma_rotation);
    return positivePart(l.covariance - Matrix6d(floorVariances(config_.loop_closure.verification).asDiagonal())) +
           Matrix6d(translationRotationDiagonal(t2, r2).asDiagonal());
  }

  /// SlamConfig::loop_bias: groups of loops within loop_bias_window keyframes of the group's first
  /// loop at both ends (taken in the order of their query keyframes), one bias node per group with
  /// prior σ loop_shared_sigma_*; the bias is a left perturbation in the first loop's old keyframe,
  /// moved into each loop's old keyframe with the current poses. Loop edges from `first` on.
  void attachLoopBiases(const std::vector<LoopClosure>& loops, int first) {
    PoseGraph& graph = result_.graph;
    std::vector<std::size_t> order(loops.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
      return std::pair(loops[a].to, loops[a].from) < std::pair(loops[b].to, loops[b].from);
    });
    const auto near = [w = config_.loop_bias_window](std::size_t a, std::size_t b) { return (a > b ? a - b : b - a) <= w; };
    const auto sq = [](double s) { return 1.0 / (s * s); };
    const double it = sq(config_.loop_shared_sigma_translation), ir = sq(config_.loop_shared_sigma_rotation);
    const Matrix6d prior = translationRotationDiagonal(it, ir).asDiagonal();
    std::vector<std::pair<std::size_t, int>> groups;  // (first loop, bias node)
    for (std::size_t i : order) {
      const LoopClosure& l = loops[i];
      auto g = std::find_if(groups.begin(), groups.end(), [&](const auto& grp) {
        return near(loops[grp.first].from, l.from) && near(loops[grp.first].to, l.to);
      });
      if (g == groups.end()) g = groups.insert(groups.end(), {i, graph.addBias(prior)});
      const Eigen::Isometry3d& T_ref = graph.poses[keyframe_frames_[loops[g->first].from]];
      const Eigen::Isometry3d& T_old = graph.poses[keyframe_frames_[l.from]];
      graph.attachBias(first + static_cast<int>(i), g->second, adjoint(T_old.inverse() * T_ref));
    }
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
  std::vector<Matrix6d> unverified_step_covariance_;  // the same, zero where a registration vouches for it
  std::vector<Matrix6d> guess_step_covariance_;       // frame index → FrameRecord::guess_covariance
  struct AnchorCovariance {
    std::size_t from, to;  // frames
    Matrix6d own;          // the registration's and the anchor's own (anchorCovariance)
    Matrix6d shared;       // the chained dead-reckoned steps it spans (anchors_carry_guess_directions)
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
