// Gravity from the accelerometer (include/hazmap/preprocess/imu_gravity.hpp).
#include "hazmap/preprocess/imu_gravity.hpp"

#include <algorithm>
#include <cmath>

#include "hazmap/preprocess/imu_motion.hpp"

namespace hazmap {

namespace {

constexpr double kWindow = 1.0;  // s either side of the stamp: the gyro's bias turns it by ≤ 0.1° there
constexpr std::size_t kMinSamples = 10;
constexpr double kGravity = 9.80665;             // m/s²
constexpr double kMaxMagnitudeError = 0.1;       // share of g
// m/s²: the accelerometer's own offset, not estimated here — a BMI088-class MEMS part's zero-g
// offset is ±20 mg typical (datasheet); 0.1 m/s² made naraha's maps worse than no prior on 2 of 8
// seeds (the offset is the same for every keyframe, so the graph averages it in), 0.2 on 1 of 8.
constexpr double kAccelerometerOffset = 0.2;
constexpr double kMaxSigmaDeg = 5.0;
constexpr double kDeg = 180.0 / 3.14159265358979323846;

}  // namespace

std::optional<GravitySample> gravityFromAccelerometer(const std::vector<ImuSample>& samples, double stamp,
                                                      double acceleration, const Eigen::Vector3d& gyro_bias) {
  const auto byTime = [](const ImuSample& s, double t) { return s.time < t; };
  const auto first = std::lower_bound(samples.begin(), samples.end(), stamp - kWindow, byTime);
  const auto last = std::upper_bound(samples.begin(), samples.end(), stamp + kWindow,
                                     [](double t, const ImuSample& s) { return t < s.time; });
  const std::vector<ImuSample> window(first, last);
  if (window.size() < kMinSamples) return std::nullopt;
  const GyroAttitude attitude(window, gyro_bias);
  const Eigen::Matrix3d R_stamp_first = attitude.at(stamp).transpose();
  std::vector<Eigen::Vector3d> force;
  force.reserve(window.size());
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const ImuSample& s : window) {
    force.push_back(R_stamp_first * attitude.at(s.time) * s.accel);
    mean += force.back();
  }
  const double n = static_cast<double>(window.size());
  mean /= n;
  const double magnitude = mean.norm();
  if (!std::isfinite(magnitude) || std::abs(magnitude - kGravity) > kMaxMagnitudeError * kGravity) return std::nullopt;
  double spread2 = 0.0;  // per axis
  for (const Eigen::Vector3d& f : force) spread2 += (f - mean).squaredNorm() / 3.0;
  spread2 /= std::max(n - 1.0, 1.0);
  // The sensor's own acceleration: what tracking says, at least what the mean's length says.
  const double a = std::max(std::abs(acceleration), std::abs(magnitude - kGravity));
  const double sigma_rad = std::sqrt(spread2 / n + kAccelerometerOffset * kAccelerometerOffset + a * a) / kGravity;
  GravitySample out;
  out.time = stamp;
  out.down = -mean / magnitude;
  out.sigma_deg = std::atan(sigma_rad) * kDeg;
  if (!(out.sigma_deg <= kMaxSigmaDeg)) return std::nullopt;
  return out;
}

}  // namespace hazmap
