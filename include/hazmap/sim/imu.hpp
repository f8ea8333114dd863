#pragma once
// The crawler's IMU as an AHRS: per scan, the direction of gravity in the sensor frame. A
// crawler at 0.1 m/s accelerates by millimetres per s², so its accelerometers measure gravity
// alone and fix roll and pitch absolutely (yaw is not observable from gravity). The error of an
// industrial AHRS's roll and pitch is ~0.1–0.3° (e.g. Xsens MTi-30: 0.2° static); it is modelled
// as an independent N(0, σ) rotation about each of the two axes perpendicular to gravity.
#include <Eigen/Geometry>
#include <cstdint>

#include <vector>

#include "hazmap/io/gravity.hpp"
#include "hazmap/io/imu.hpp"

namespace hazmap::sim {

/// The raw IMU stream (imu.txt), off unless rate_hz > 0. White noise densities are the Bosch
/// BMI088's datasheet values (BST-BMI088-DS001, table 1/2: gyro 0.014 °/s/√Hz, accelerometer
/// 175 µg/√Hz); the datasheet gives no bias random walk, so those are Kalibr's values for the
/// EuRoC MAV's ADIS16448 (gyro 1.9393e-5 rad/s²/√Hz, accelerometer 3e-3 m/s³/√Hz), a MEMS IMU
/// of the same class.
struct ImuConfig {
  bool enabled = true;             ///< write gravity.txt
  double gravity_sigma_deg = 0.2;  ///< ° per axis, the AHRS's roll/pitch accuracy
  double rate_hz = 0.0;            ///< imu.txt's sample rate; 0: no imu.txt
  double gyro_noise_density = 0.014;   ///< °/s/√Hz
  double accel_noise_density = 175.0;  ///< µg/√Hz
  double gyro_bias_sigma = 0.1;        ///< °/s, turn-on bias left after a calibration at rest
  double gyro_bias_walk = 1.9393e-5;   ///< rad/s²/√Hz
  double accel_bias_walk = 3.0e-3;     ///< m/s³/√Hz
};

/// Frame `index`'s gravity sample from the true sensor pose in a gravity-aligned world (z up),
/// with noise from its own random stream (RngStream::Imu), so the IMU never changes the scans,
/// odometry or labels of a seed.
GravitySample simulateGravity(const Eigen::Isometry3d& T_world_sensor, double time, const ImuConfig& config,
                              std::uint64_t seed, std::size_t index);

/// The IMU's samples (sensor frame) at config.rate_hz from the first to the last frame time,
/// along the true sensor poses `T_world_sensor` (gravity-aligned world, z up) at `times`: between
/// two frames the sensor turns at a constant rate and moves along a C¹ cubic (Hermite, velocities
/// from the neighbouring frames, at rest at both ends), so the accelerometer sees the robot's
/// accelerations and gravity. Noise from its own random stream (RngStream::ImuStream): adding the
/// IMU changes nothing else of a seed.
std::vector<ImuSample> simulateImuStream(const std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>& T_world_sensor,
                                         const std::vector<double>& times, const ImuConfig& config,
                                         std::uint64_t seed);

}  // namespace hazmap::sim
