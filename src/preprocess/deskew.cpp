#include "hazmap/preprocess/deskew.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "hazmap/core/error.hpp"

namespace hazmap {

Vector6d velocityOfIncrement(const Eigen::Isometry3d& T_prev_curr, double dt) {
  if (!(dt > 0.0) || !std::isfinite(dt)) fail("deskew", "increment duration must be > 0 s");
  return se3Log(T_prev_curr) / dt;
}

std::size_t deskewScan(LabeledCloud& cloud, const Vector6d& velocity, double reference_time) {
  if (cloud.timestamps.size() != cloud.size() || cloud.empty()) return 0;
  if (velocity.isZero(0.0)) return 0;
  // A spinning LiDAR's points come in time order over < 1 s; one exponential per point costs
  // ~100 ns, far below the registration's cost, so no interpolation table is needed.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cloud.size(), 4096),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i < range.end(); ++i) {
                        const double dt = cloud.timestamps[i] - reference_time;
                        if (!std::isfinite(dt)) continue;
                        const Eigen::Isometry3d T_ref_point = se3Exp(velocity * dt);
                        cloud.points[i] =
                            (T_ref_point * cloud.points[i].cast<double>()).cast<float>();
                      }
                    });
  return cloud.size();
}

std::optional<Vector6d> StreamDeskewer::applyGyro(LabeledCloud& cloud, double stamp, std::optional<double> before,
                                                  const std::optional<Eigen::Isometry3d>& wheel_increment,
                                                  const GyroAttitude& gyro) const {
  Eigen::Vector3d linear = Eigen::Vector3d::Zero();
  if (before && config_.motion == DeskewMotion::WheelOdometry && wheel_increment && stamp - *before > 0.0 &&
      stamp - *before <= config_.max_increment_gap)
    linear = velocityOfIncrement(*wheel_increment, stamp - *before).head<3>();
  else if (last_increment_ && *last_increment_dt_ > 0.0 && *last_increment_dt_ <= config_.max_increment_gap)
    linear = velocityOfIncrement(*last_increment_, *last_increment_dt_).head<3>();
  const auto [lo, hi] = std::minmax_element(cloud.timestamps.begin(), cloud.timestamps.end());
  if (deskewScanWithGyro(cloud, gyro, linear, stamp) == 0) return std::nullopt;
  Vector6d velocity;
  const Eigen::Vector3d angular =
      *hi > *lo ? Eigen::Vector3d(so3Log(gyro.between(*lo, *hi)) / (*hi - *lo)) : Eigen::Vector3d::Zero();
  velocity << linear, angular;
  return velocity;
}

std::optional<Vector6d> StreamDeskewer::apply(LabeledCloud& cloud, double stamp,
                                              const std::optional<Eigen::Isometry3d>& wheel_increment,
                                              const GyroAttitude* gyro) {
  // The last tracked increment spans the two scans before this one.
  if (pending_increment_ && prev_stamp_ && stamp_) {
    last_increment_ = pending_increment_;
    last_increment_dt_ = *stamp_ - *prev_stamp_;
  }
  pending_increment_.reset();
  const std::optional<double> before = stamp_;
  prev_stamp_ = stamp_;
  stamp_ = stamp;
  if (!config_.enabled || !cloud.hasTimestamps()) return std::nullopt;
  if (gyro && !gyro->empty())
    if (auto v = applyGyro(cloud, stamp, before, wheel_increment, *gyro)) return v;
  if (!before) return std::nullopt;
  std::optional<Eigen::Isometry3d> increment;
  double dt = 0.0;
  if (config_.motion == DeskewMotion::WheelOdometry && wheel_increment) {
    increment = wheel_increment;
    dt = stamp - *before;
  } else if (last_increment_) {
    increment = last_increment_;
    dt = *last_increment_dt_;
  }
  if (!increment || !(dt > 0.0) || dt > config_.max_increment_gap) return std::nullopt;
  const Vector6d velocity = velocityOfIncrement(*increment, dt);
  deskewScan(cloud, velocity, stamp);
  return velocity;
}

void StreamDeskewer::tracked(const Eigen::Isometry3d& T_prev_curr) { pending_increment_ = T_prev_curr; }

}  // namespace hazmap
