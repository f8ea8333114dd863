#pragma once
// The IMU's mounting in the LiDAR (R_lidar_imu) as a user writes it: `--imu-rotation` for a bag's
// sensor_msgs/Imu whose samples are in the IMU's own axes. Only the rotation matters to what the
// samples are used for (the gyro's turn, the accelerometer's gravity); a lever arm adds a
// centripetal term of ω²·r (0.01 m/s² for 0.1 m at 0.3 rad/s) and is not applied.
#include <Eigen/Core>
#include <string>

namespace hazmap {

/// Parses "roll,pitch,yaw" (degrees; R = Rz(yaw)·Ry(pitch)·Rx(roll)), "qw,qx,qy,qz" (a unit
/// quaternion), nine numbers (the rotation, row-major) or sixteen (the 4×4 T_lidar_imu, row-major;
/// its translation ignored). Commas and/or spaces separate. Throws hazmap::Error("<where>: …") for
/// another count, a non-number, NaN/inf, a quaternion whose norm is off 1 by more than 1e-3, a
/// matrix that is not a rotation (‖RᵀR − I‖ > 1e-3 or det < 0), or a 4×4 whose last row is not 0 0 0 1.
Eigen::Matrix3d parseImuRotation(const std::string& text, const std::string& where);

}  // namespace hazmap
