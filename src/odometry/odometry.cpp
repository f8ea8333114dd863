#include "hazmap/odometry/odometry.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>

#include <tbb/parallel_invoke.h>

#include "hazmap/core/error.hpp"
#include "hazmap/preprocess/crop.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/registration/registration_target.hpp"

namespace hazmap {

const char* toString(OdometryMode mode) { return mode == OdometryMode::FrameToFrame ? "frame" : "map"; }

const char* toString(FrameStatus status) {
  switch (status) {
    case FrameStatus::First: return "first";
    case FrameStatus::Registered: return "registered";
    case FrameStatus::Degenerate: return "degenerate";
    case FrameStatus::Fallback: return "fallback";
  }
  return "unknown";
}

struct Odometry::Impl {
  std::unique_ptr<RegistrationTarget> previous;  ///< FrameToFrame: the last non-empty scan
  Eigen::Isometry3d previous_pose = Eigen::Isometry3d::Identity();  ///< its pose (world ← scan)
  Eigen::Isometry3d velocity = Eigen::Isometry3d::Identity();  ///< last increment
  bool has_velocity = false;
};

Odometry::Odometry(const ClassTable& classes, const OdometryConfig& config,
                   const Eigen::Isometry3d& initial_pose)
    : classes_(classes), config_(config), initial_pose_(initial_pose), map_(config.map),
      impl_(std::make_unique<Impl>()) {
  config_.validate();
  if (!isFinite(initial_pose)) fail("odometry", "initial pose has a non-finite entry");
}

Odometry::~Odometry() = default;

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

Matrix6d fallbackCovariance(const OdometryConfig& c) {
  Vector6d d;
  const double t2 = c.fallback_sigma_translation * c.fallback_sigma_translation;
  const double r2 = c.fallback_sigma_rotation * c.fallback_sigma_rotation;
  d << t2, t2, t2, r2, r2, r2;
  return d.asDiagonal();
}

}  // namespace

const OdometryFrame& Odometry::addFrame(const LabeledCloud& scan,
                                        const std::optional<Eigen::Isometry3d>& wheel_increment,
                                        double stamp) {
  const auto t_start = Clock::now();
  const std::size_t index = frames_.size();
  const std::string where = "odometry frame " + std::to_string(index);
  if (wheel_increment && !isFinite(*wheel_increment)) fail(where, "wheel odometry increment is not finite");
  scan.checkConsistent(where);
  const RegistrationConfig& rc = config_.registration;
  if (rc.use_classes) classes_.checkCloud(scan, where);

  // 1. preprocessing: crop, downsample keeping property classes. Frame to map, the local map's
  //    registration target is built meanwhile: it does not depend on this scan, and a
  //    downsampling has a serial pass that leaves the other cores idle.
  RangeCropConfig crop;
  crop.min_range = config_.min_range;
  crop.max_range = config_.max_range;
  VoxelDownsampleConfig vd;
  vd.voxel_size = config_.voxel_size;
  vd.vote = ClassVote::PreferProperty;
  const bool separate_source = config_.source_voxel_size > config_.voxel_size;
  LabeledCloud frame, coarse;
  double preprocess_ms = 0.0;
  const auto preprocess = [&] {
    const auto t = Clock::now();
    frame = cropAndDownsample(scan, crop, vd, classes_);
    if (separate_source) {
      VoxelDownsampleConfig vs = vd;
      vs.voxel_size = config_.source_voxel_size;
      coarse = voxelDownsample(frame, vs, classes_);
    }
    preprocess_ms = msSince(t);
  };
  const bool to_map = config_.mode == OdometryMode::FrameToMap;
  std::optional<RegistrationTarget> map_target;
  if (to_map && !frames_.empty()) {
    // Lazy normals: ICP estimates only those of the map points it pairs with.
    tbb::parallel_invoke(preprocess, [&] { map_target.emplace(map_.makeTarget(classes_, rc, /*lazy_normals=*/true)); });
  } else {
    preprocess();
  }
  const LabeledCloud& source = separate_source ? coarse : frame;

  OdometryFrame f;
  f.index = index;
  f.stamp = stamp >= 0.0 ? stamp : static_cast<double>(index);
  f.scan_points = scan.size();
  f.source_points = source.size();
  f.preprocess_ms = preprocess_ms;

  if (frames_.empty()) {
    f.pose = initial_pose_;
    f.status = FrameStatus::First;
  } else {
    const Eigen::Isometry3d prev_pose = frames_.back().pose;
    f.wheel_guess = wheel_increment.has_value();
    f.guess = wheel_increment ? *wheel_increment
                              : (impl_->has_velocity ? impl_->velocity : Eigen::Isometry3d::Identity());
    // Registration in its own space W: FrameToMap estimates world ← current, FrameToFrame
    // target-scan ← current (the target is the last non-empty scan, normally the previous one).
    const Eigen::Isometry3d W = to_map ? Eigen::Isometry3d::Identity() : impl_->previous_pose;
    const Eigen::Isometry3d reg_guess = W.inverse() * prev_pose * f.guess;
    RegistrationResult r;
    if (to_map) {
      f.map_points = map_target->size();
      r = registerClouds(source, *map_target, reg_guess, classes_, rc);
      map_target.reset();  // its lazy normals read the map, which changes below
    } else {
      if (impl_->previous) {
        f.map_points = impl_->previous->size();
        r = registerClouds(source, *impl_->previous, reg_guess, classes_, rc);
      } else {
        r.reason = "no previous scan to register against";
      }
    }
    // 2. failure detection
    std::string failure;
    const bool hit_limit = !r.converged && r.reason.rfind("reached max_iterations", 0) == 0;
    if (!r.converged && !hit_limit) failure = r.reason;
    else if (r.fitness < config_.min_fitness) {
      char buf[128];
      std::snprintf(buf, sizeof buf, "fitness %.3f below min_fitness %.3f", r.fitness, config_.min_fitness);
      failure = buf;
    } else {
      const Vector6d correction = se3Log(r.transform * reg_guess.inverse());
      const double dt = correction.head<3>().norm(), dr = correction.tail<3>().norm();
      if (dt > config_.max_correction_translation || dr > config_.max_correction_rotation) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "diverged: %.3f m / %.2f deg from the guess (limits %.3f m / %.2f deg)",
                      dt, dr * 180.0 / M_PI, config_.max_correction_translation,
                      config_.max_correction_rotation * 180.0 / M_PI);
        failure = buf;
      }
    }
    Eigen::Isometry3d estimate = r.transform;  // in registration space
    Matrix6d cov = r.covariance;
    if (!failure.empty()) {
      f.status = FrameStatus::Fallback;
      f.reason = failure;
      estimate = reg_guess;
    } else if (!r.degenerate_directions.empty() && config_.keep_guess_along_degenerate) {
      // Keep ICP's answer where it is constrained and the guess along degenerate directions.
      std::vector<Vector6d> basis;
      for (Vector6d d : r.degenerate_directions) {
        for (const auto& b : basis) d -= b.dot(d) * b;
        if (d.norm() > 1e-6) basis.push_back(d.normalized());
      }
      Vector6d delta = se3Log(r.transform * reg_guess.inverse());
      Matrix6d P = Matrix6d::Identity();
      for (const auto& b : basis) {
        delta -= b.dot(delta) * b;
        P -= b * b.transpose();
      }
      estimate = normalized(se3Exp(delta) * reg_guess);
      cov = P * cov * P.transpose();
      const Matrix6d fb = fallbackCovariance(config_);
      for (const auto& b : basis) cov += (b.transpose() * fb * b)(0, 0) * b * b.transpose();
      f.status = FrameStatus::Degenerate;
      char buf[64];
      std::snprintf(buf, sizeof buf, "%zu degenerate direction(s); guess kept along ", basis.size());
      f.reason = buf;
      for (std::size_t k = 0; k < basis.size(); ++k) {
        char d[96];
        const Vector6d& b = basis[k];
        std::snprintf(d, sizeof d, "%s[%.2f %.2f %.2f %.2f %.2f %.2f]", k ? ", " : "", b(0), b(1), b(2),
                      b(3), b(4), b(5));
        f.reason += d;
      }
    } else {
      f.status = FrameStatus::Registered;
    }
    f.increment = normalized(prev_pose.inverse() * W * estimate);
    // W-frame perturbation → previous-frame perturbation of the increment
    const Matrix6d Ad = adjoint(prev_pose.inverse() * W);
    f.covariance = f.status == FrameStatus::Fallback ? fallbackCovariance(config_)
                                                     : Matrix6d(Ad * cov * Ad.transpose());
    f.pose = normalized(prev_pose * f.increment);
    f.registration = std::move(r);
    impl_->velocity = f.increment;
    impl_->has_velocity = true;
  }

  // 3. update the map / the previous scan
  if (config_.mode == OdometryMode::FrameToMap) {
    map_.integrate(frame.transformed(f.pose), f.pose.translation(), classes_);
    f.map_points = map_.size();
  } else if (!frame.empty() || !impl_->previous) {
    impl_->previous = std::make_unique<RegistrationTarget>(frame, classes_, rc);
    impl_->previous_pose = f.pose;
  }
  f.total_ms = msSince(t_start);
  f.registration_ms = f.total_ms - f.preprocess_ms;
  frames_.push_back(std::move(f));
  return frames_.back();
}

Trajectory Odometry::trajectory() const {
  Trajectory t;
  for (const auto& f : frames_) t.push_back(f.stamp, f.pose);
  return t;
}

}  // namespace hazmap
