// The simulated AHRS's gravity direction per scan (include/hazmap/sim/imu.hpp).
#include "hazmap/sim/imu.hpp"

#include "hazmap/core/se3.hpp"
#include "hazmap/sim/random.hpp"

namespace hazmap::sim {

GravitySample simulateGravity(const Eigen::Isometry3d& T_world_sensor, double time, const ImuConfig& config,
                              std::uint64_t seed, std::size_t index) {
  const Eigen::Vector3d down = T_world_sensor.linear().transpose() * Eigen::Vector3d(0.0, 0.0, -1.0);
  // Two axes perpendicular to gravity: the roll and pitch errors of the AHRS.
  const Eigen::Vector3d e1 = down.unitOrthogonal();
  const Eigen::Vector3d e2 = down.cross(e1);
  Rng rng(seed, RngStream::Imu, index);
  const double sigma = config.gravity_sigma_deg * M_PI / 180.0;
  const double a = rng.normal(sigma), b = rng.normal(sigma);
  GravitySample s;
  s.time = time;
  s.down = (so3Exp(a * e1 + b * e2) * down).normalized();
  s.sigma_deg = config.gravity_sigma_deg;
  return s;
}

}  // namespace hazmap::sim
