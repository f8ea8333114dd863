#pragma once
// Gravity's direction from the accelerometer (Scan::imu): the pose graph's gravity priors for a
// recording with an IMU but no AHRS output (no gravity.txt, docs/formats.md).
#include <Eigen/Core>
#include <optional>
#include <vector>

#include "hazmap/io/gravity.hpp"
#include "hazmap/io/imu.hpp"

namespace hazmap {

/// Gravity's direction at `stamp` in the sensor frame: the accelerometer's samples within a second
/// of `stamp`, each turned into the frame at `stamp` by the gyro (less `gyro_bias`), averaged
/// and negated (at rest or at constant velocity the specific force is −g). `acceleration` (m/s²)
/// is how much the sensor itself may have accelerated meanwhile (e.g. from the tracked motion):
/// that tilts the mean by up to atan(a / g), so it widens σ, as do the samples' spread over √n and
/// the accelerometer's offset (0.2 m/s², about 1.2°: a MEMS part's zero-g offset). nullopt with fewer than 10 samples
/// there, a mean specific force more than 10 % off standard gravity (falling, bouncing),
/// or a σ above 5° (it would say nothing).
std::optional<GravitySample> gravityFromAccelerometer(const std::vector<ImuSample>& samples, double stamp,
                                                      double acceleration,
                                                      const Eigen::Vector3d& gyro_bias = Eigen::Vector3d::Zero());

}  // namespace hazmap
