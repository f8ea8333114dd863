// The simulated IMU's raw samples (simulateImuStream in include/hazmap/sim/imu.hpp).
#include <algorithm>
#include <cmath>

#include "hazmap/core/se3.hpp"
#include "hazmap/sim/imu.hpp"
#include "hazmap/sim/random.hpp"

namespace hazmap::sim {

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kGravity = 9.80665;  // m/s², standard gravity (and the µg of the datasheet)

using Poses = std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>;

/// Velocity at frame i: central difference, at rest at the ends.
Eigen::Vector3d frameVelocity(const Poses& T, const std::vector<double>& t, std::size_t i) {
  if (i == 0 || i + 1 >= T.size()) return Eigen::Vector3d::Zero();
  return (T[i + 1].translation() - T[i - 1].translation()) / (t[i + 1] - t[i - 1]);
}

/// True angular velocity (sensor frame) and specific force at time `tau` in [t_i, t_i+1].
ImuSample trueSample(const Poses& T, const std::vector<double>& t, std::size_t i, double tau) {
  const double h = t[i + 1] - t[i];
  const double s = std::clamp((tau - t[i]) / h, 0.0, 1.0);
  const Eigen::Vector3d omega = so3Log(T[i].linear().transpose() * T[i + 1].linear()) / h;
  const Eigen::Matrix3d R = T[i].linear() * so3Exp(omega * (s * h));
  // Hermite cubic p(s) = h00 p0 + h10 h v0 + h01 p1 + h11 h v1: its second derivative in time.
  const Eigen::Vector3d p0 = T[i].translation(), p1 = T[i + 1].translation();
  const Eigen::Vector3d v0 = frameVelocity(T, t, i), v1 = frameVelocity(T, t, i + 1);
  const Eigen::Vector3d accel = ((12.0 * s - 6.0) * (p0 - p1) + (6.0 * s - 4.0) * h * v0 + (6.0 * s - 2.0) * h * v1) / (h * h);
  ImuSample out;
  out.time = tau;
  out.gyro = omega;
  out.accel = R.transpose() * (accel + Eigen::Vector3d(0.0, 0.0, kGravity));
  return out;
}

Eigen::Vector3d normal3(Rng& rng, double sigma) {
  const double x = rng.normal(sigma), y = rng.normal(sigma), z = rng.normal(sigma);
  return {x, y, z};
}

}  // namespace

std::vector<ImuSample> simulateImuStream(const Poses& T_world_sensor, const std::vector<double>& times,
                                         const ImuConfig& config, std::uint64_t seed) {
  std::vector<ImuSample> out;
  if (config.rate_hz <= 0.0 || times.size() < 2) return out;
  const double dt = 1.0 / config.rate_hz;
  // Discrete white noise: σ = density · √rate; bias random walk: σ per step = density · √dt.
  const double gyro_sigma = config.gyro_noise_density * kDeg * std::sqrt(config.rate_hz);
  const double accel_sigma = config.accel_noise_density * 1e-6 * kGravity * std::sqrt(config.rate_hz);
  Rng start(seed, RngStream::ImuStream, 0);
  Eigen::Vector3d gyro_bias = normal3(start, config.gyro_bias_sigma * kDeg);
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
  std::size_t interval = 0;
  const auto count = static_cast<std::size_t>(std::floor((times.back() - times.front()) * config.rate_hz)) + 1;
  out.reserve(count);
  for (std::size_t k = 0; k < count; ++k) {
    const double tau = times.front() + static_cast<double>(k) * dt;
    while (interval + 2 < times.size() && tau > times[interval + 1]) ++interval;
    ImuSample sample = trueSample(T_world_sensor, times, interval, tau);
    Rng rng(seed, RngStream::ImuStream, k + 1);
    sample.gyro += gyro_bias + normal3(rng, gyro_sigma);
    sample.accel += accel_bias + normal3(rng, accel_sigma);
    gyro_bias += normal3(rng, config.gyro_bias_walk * std::sqrt(dt));
    accel_bias += normal3(rng, config.accel_bias_walk * std::sqrt(dt));
    out.push_back(sample);
  }
  return out;
}

}  // namespace hazmap::sim
