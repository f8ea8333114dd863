#include "hazmap/pipeline/slam.hpp"

#include <tbb/global_control.h>
#include <Eigen/Eigenvalues>

#include <chrono>
#include <cmath>
#include <memory>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/atomic_file.hpp"

namespace hazmap {

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// A floor on the standard deviations before inverting a covariance: an over-confident ICP
// covariance (few, noise-free points) must not make an edge rigid.
Matrix6d flooredInformation(const Matrix6d& covariance, double min_translation_sigma,
                            double min_rotation_sigma) {
  Matrix6d c = 0.5 * (covariance + covariance.transpose());
  for (int i = 0; i < 3; ++i) c(i, i) = std::max(c(i, i), min_translation_sigma * min_translation_sigma);
  for (int i = 3; i < 6; ++i) c(i, i) = std::max(c(i, i), min_rotation_sigma * min_rotation_sigma);
  Eigen::SelfAdjointEigenSolver<Matrix6d> eig(c);
  Eigen::Matrix<double, 6, 1> values = eig.eigenvalues().cwiseMax(1e-12);
  return eig.eigenvectors() * values.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
}

Trajectory trajectoryOf(const std::vector<Eigen::Isometry3d>& poses) {
  Trajectory t;
  for (std::size_t i = 0; i < poses.size(); ++i) t.push_back(static_cast<double>(i), poses[i]);
  return t;
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

double SlamResult::framesPerSecond() const {
  return timings.total_s > 0 ? static_cast<double>(frames.size()) / timings.total_s : 0.0;
}

SlamResult runSlam(const Sequence& sequence, const SlamConfig& config, const FrameProgress& progress) {
  config.validate();
  const std::string where = sequence.directory().string();
  const std::size_t n = sequence.size();
  if (n == 0) fail(where, "sequence has no scans");
  const auto& odometry = sequence.odometry();
  if (odometry && odometry->size() != n)
    fail(where, "odometry.txt has " + std::to_string(odometry->size()) + " poses for " +
                    std::to_string(n) + " scans");
  if (config.method == SlamMethod::Odometry && !odometry)
    fail(where, "method 'odometry' needs wheel odometry (odometry.txt)");
  std::unique_ptr<tbb::global_control> threads;
  if (config.threads > 0)
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    static_cast<std::size_t>(config.threads));

  const auto t_start = Clock::now();
  SlamResult result;
  result.method = config.method;
  const auto& truth = sequence.groundTruth();
  const Eigen::Isometry3d start = truth && !truth->empty() ? truth->poses.front()
                                  : odometry                ? odometry->poses.front()
                                                            : Eigen::Isometry3d::Identity();
  // Wheel odometry expressed from the common start pose.
  std::vector<Eigen::Isometry3d> odom_poses;
  if (odometry) {
    const Eigen::Isometry3d T_start_odom0 = start * odometry->poses.front().inverse();
    for (const auto& p : odometry->poses) odom_poses.push_back(normalized(T_start_odom0 * p));
    result.odometry_only = trajectoryOf(odom_poses);
  }

  // α and the class search radii, set once for tracking and loop verification alike.
  const ClassTable classes = config.property_icp.applyTo(sequence.classTable(), where);
  PoseGraph& graph = result.graph;
  graph.dimension = 3;
  std::vector<Eigen::Isometry3d> tracked;
  const bool pgo = usesPoseGraph(config.method);
  std::unique_ptr<LoopDetector> loops;
  std::vector<std::size_t> keyframe_frames;  // keyframe index → frame index
  if (pgo) {
    loops = std::make_unique<LoopDetector>(classes, config.loop_closure);
    // Old keyframes are re-read from the sequence when a loop needs them (bounded memory).
    loops->setCloudLoader([&](std::size_t k) { return sequence.frame(keyframe_frames.at(k)); });
  }
  Odometry tracker(classes, config.odometry, start);
  Eigen::Isometry3d last_keyframe_pose = Eigen::Isometry3d::Identity();

  const auto keyframeEstimate = [&] {
    PoseList poses;
    for (std::size_t f : keyframe_frames) poses.push_back(graph.poses[f]);
    return poses;
  };
  const auto optimise = [&] {
    const auto t = Clock::now();
    result.optimisations.push_back(optimizePoseGraph(graph, config.graph));
    result.timings.graph_s += secondsSince(t);
  };

  for (std::size_t i = 0; i < n; ++i) {
    const auto t_frame = Clock::now();
    FrameRecord rec;
    rec.index = i;
    std::optional<Eigen::Isometry3d> odom_increment;
    if (odometry && i > 0) odom_increment = odom_poses[i - 1].inverse() * odom_poses[i];
    LabeledCloud scan;
    if (usesIcp(config.method)) {
      scan = sequence.frame(i);
      const OdometryFrame& f = tracker.addFrame(scan, odom_increment, static_cast<double>(i));
      rec.T_prev_curr = f.increment;
      rec.covariance = f.covariance;
      rec.icp_used = f.status == FrameStatus::Registered || f.status == FrameStatus::Degenerate ||
                     f.status == FrameStatus::First;
      rec.fallback_reason = f.reason;
      rec.fitness = f.registration.fitness;
      rec.rmse = f.registration.inlier_rmse;
      rec.iterations = f.registration.iterations;
      rec.points = f.source_points;
    } else if (odom_increment) {
      rec.T_prev_curr = *odom_increment;
    }
    rec.milliseconds = 1e3 * secondsSince(t_frame);
    result.timings.tracking_s += secondsSince(t_frame);

    result.frames.push_back(rec);
    const Eigen::Isometry3d pose = i == 0 ? start : normalized(tracked.back() * rec.T_prev_curr);
    tracked.push_back(pose);
    // Every method records its graph (graph.g2o); only the PGO methods add loops and optimise.
    // A new node continues from the (possibly already optimised) previous node.
    graph.addNode(i == 0 ? start : normalized(graph.poses.back() * rec.T_prev_curr));
    if (i > 0) {
      const Matrix6d info = rec.icp_used
                                ? flooredInformation(rec.covariance, config.min_translation_sigma,
                                                     config.min_rotation_sigma)
                                : config.wheel_noise.information();
      graph.addEdge(static_cast<int>(i - 1), static_cast<int>(i), rec.T_prev_curr, info,
                    EdgeKind::Odometry);
    }
    if (pgo) {
      const Eigen::Isometry3d since = last_keyframe_pose.inverse() * pose;
      if (i == 0 || translationNorm(since) >= config.keyframe_distance ||
          rotationAngle(since) >= config.keyframe_angle) {
        const auto t_loop = Clock::now();
        last_keyframe_pose = pose;
        keyframe_frames.push_back(i);
        const std::size_t k = loops->addKeyframe(std::move(scan));
        const LoopDetection detection = loops->detect(k, keyframeEstimate());
        result.loop_candidates += detection.candidates.size();
        for (const auto& v : detection.verifications) result.loops_verified += v.accepted ? 1 : 0;
        result.timings.loop_s += secondsSince(t_loop);
        if (!detection.accepted.empty() && config.optimise_online) {
          const auto consistent = loops->consistentLoops(keyframeEstimate());
          // Rebuild the loop edges from the consistent set, then optimise.
          std::erase_if(graph.edges, [](const PoseGraphEdge& e) { return e.kind == EdgeKind::Loop; });
          for (const auto& l : consistent)
            graph.addEdge(static_cast<int>(keyframe_frames[l.from]),
                          static_cast<int>(keyframe_frames[l.to]), l.T_from_to, l.information,
                          EdgeKind::Loop);
          optimise();
        }
      }
    }
    if (progress) progress(i + 1, n);
  }

  result.tracked = trajectoryOf(tracked);
  if (pgo) {
    result.keyframes = keyframe_frames.size();
    const auto consistent = loops->consistentLoops(keyframeEstimate());
    std::erase_if(graph.edges, [](const PoseGraphEdge& e) { return e.kind == EdgeKind::Loop; });
    for (const auto& l : consistent) {
      graph.addEdge(static_cast<int>(keyframe_frames[l.from]), static_cast<int>(keyframe_frames[l.to]),
                    l.T_from_to, l.information, EdgeKind::Loop);
      result.loops.push_back({keyframe_frames[l.from], keyframe_frames[l.to], toString(l.source),
                              l.fitness, l.rmse});
    }
    if (!consistent.empty()) optimise();
    result.estimate = trajectoryOf(graph.poses);
  } else if (config.method == SlamMethod::Odometry) {
    result.estimate = result.odometry_only;
  } else {
    result.estimate = result.tracked;
  }
  result.timings.total_s = secondsSince(t_start);
  return result;
}

}  // namespace hazmap
