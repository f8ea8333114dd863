#pragma once
// The crawler's IMU as an AHRS: per scan, the direction of gravity in the sensor frame. A
// crawler at 0.1 m/s accelerates by millimetres per s², so its accelerometers measure gravity
// alone and fix roll and pitch absolutely (yaw is not observable from gravity). The error of an
// industrial AHRS's roll and pitch is ~0.1–0.3° (e.g. Xsens MTi-30: 0.2° static); it is modelled
// as an independent N(0, σ) rotation about each of the two axes perpendicular to gravity.
#include <Eigen/Geometry>
#include <cstdint>

#include "hazmap/io/gravity.hpp"

namespace hazmap::sim {

struct ImuConfig {
  bool enabled = true;             ///< write gravity.txt
  double gravity_sigma_deg = 0.2;  ///< ° per axis, the AHRS's roll/pitch accuracy
};

/// Frame `index`'s gravity sample from the true sensor pose in a gravity-aligned world (z up),
/// with noise from its own random stream (RngStream::Imu), so the IMU never changes the scans,
/// odometry or labels of a seed.
GravitySample simulateGravity(const Eigen::Isometry3d& T_world_sensor, double time, const ImuConfig& config,
                              std::uint64_t seed, std::size_t index);

}  // namespace hazmap::sim
