// Gyro attitude, gyro deskewing and the online gyro bias (include/hazmap/preprocess/imu_motion.hpp).
#include "hazmap/preprocess/imu_motion.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/core/se3.hpp"

namespace hazmap {

GyroAttitude::GyroAttitude(const std::vector<ImuSample>& samples, const Eigen::Vector3d& bias) {
  if (samples.size() < 2) return;
  times_.reserve(samples.size());
  attitude_.push_back(Eigen::Matrix3d::Identity());
  times_.push_back(samples.front().time);
  for (std::size_t k = 0; k + 1 < samples.size(); ++k) {
    const Eigen::Vector3d rate = 0.5 * (samples[k].gyro + samples[k + 1].gyro) - bias;
    rates_.push_back(rate);
    attitude_.push_back(attitude_.back() * so3Exp(rate * (samples[k + 1].time - samples[k].time)));
    times_.push_back(samples[k + 1].time);
  }
}

Eigen::Matrix3d GyroAttitude::at(double t) const {
  if (empty()) return Eigen::Matrix3d::Identity();
  t = std::clamp(t, times_.front(), times_.back());
  const auto it = std::upper_bound(times_.begin(), times_.end(), t);
  const std::size_t k = std::min<std::size_t>(static_cast<std::size_t>(it - times_.begin()) - 1, rates_.size() - 1);
  return attitude_[k] * so3Exp(rates_[k] * (t - times_[k]));
}

std::size_t deskewScanWithGyro(LabeledCloud& cloud, const GyroAttitude& attitude,
                               const Eigen::Vector3d& linear_velocity, double reference_time) {
  if (cloud.timestamps.size() != cloud.size() || cloud.empty()) return 0;
  const auto [lo, hi] = std::minmax_element(cloud.timestamps.begin(), cloud.timestamps.end());
  if (!attitude.covers(std::min(*lo, reference_time), std::max(*hi, reference_time))) return 0;
  const Eigen::Matrix3d R_ref = attitude.at(reference_time).transpose();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cloud.size(), 4096),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i < range.end(); ++i) {
                        const double dt = cloud.timestamps[i] - reference_time;
                        const Eigen::Matrix3d R_ref_point = R_ref * attitude.at(cloud.timestamps[i]);
                        cloud.points[i] =
                            (R_ref_point * cloud.points[i].cast<double>() + linear_velocity * dt).cast<float>();
                      }
                    });
  return cloud.size();
}

void GyroBiasEstimator::update(const Eigen::Matrix3d& R_gyro, const Eigen::Matrix3d& R_tracked, double dt) {
  constexpr double kGain = 0.1;                          // ~10 increments' memory
  constexpr double kLargestRate = 1.0 * M_PI / 180.0;    // rad/s: a MEMS gyro's bias is far below
  constexpr double kLargestAngle = 3.0 * M_PI / 180.0;   // rad: beyond, the registration is wrong
  if (!(dt > 0.0)) return;
  const Eigen::Vector3d angle = so3Log(R_gyro.transpose() * R_tracked);
  const Eigen::Vector3d residual = angle / dt;
  if (!residual.allFinite() || residual.norm() > kLargestRate || angle.norm() > kLargestAngle) return;
  // Measured rate = true + bias: integrating with too small a bias turns the gyro too far, and
  // the residual (tracked − gyro) is minus the bias left.
  bias_ -= kGain * residual;
}

ImuStreamMotion::Motion ImuStreamMotion::next(const std::vector<ImuSample>& imu, double stamp) {
  Motion m;
  pending_.reset();
  const std::optional<double> previous = std::exchange(last_stamp_, stamp);
  if (imu.empty()) return m;
  m.attitude.emplace(imu, bias_.bias());
  if (previous && m.attitude->covers(*previous, stamp)) {
    m.rotation = m.attitude->between(*previous, stamp);
    pending_ = m.rotation;
    pending_dt_ = stamp - *previous;
  }
  return m;
}

void ImuStreamMotion::tracked(const std::optional<Eigen::Matrix3d>& verified_rotation) {
  if (pending_ && verified_rotation) bias_.update(*pending_, *verified_rotation, pending_dt_);
  pending_.reset();
}

}  // namespace hazmap
