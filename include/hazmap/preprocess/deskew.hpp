#pragma once
// Deskewing (motion compensation) of a spinning LiDAR's scan: its points are measured over a
// whole rotation (0.1 s at 10 Hz) while the robot moves, so a scan taken at speed is smeared.
// With each point's time and the motion over the scan, every point is moved to where the sensor
// would have seen it at the scan's reference time (the middle of its sweep, Scan::stamp).
#include <Eigen/Geometry>
#include <optional>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/preprocess/imu_motion.hpp"

namespace hazmap {

enum class DeskewMotion {
  ConstantVelocity,  ///< the last tracked increment, continued over this scan (KISS-ICP's model)
  WheelOdometry,     ///< the wheel-odometry increment into this scan, when the recording has one
};

struct DeskewConfig {
  bool enabled = true;  ///< only scans with per-point times are touched
  DeskewMotion motion = DeskewMotion::ConstantVelocity;
  /// Increments over longer gaps (a dropped scan, a pause in the recording) say little about the
  /// motion during this scan: no deskewing then (s).
  double max_increment_gap = 0.5;
};

/// Body-frame velocity [vx vy vz wx wy wz] (m/s, rad/s; translation first) of a constant motion
/// that moves the sensor by `T_prev_curr` in `dt` seconds (dt > 0).
Vector6d velocityOfIncrement(const Eigen::Isometry3d& T_prev_curr, double dt);

/// Moves every point, measured at cloud.timestamps[i] in the sensor frame of that instant, into
/// the sensor frame at `reference_time`, with the sensor moving at the constant body-frame
/// `velocity`: p_ref = exp(velocity · (t_i − reference_time)) · p_i. Returns the number of points
/// moved; a cloud without timestamps is left as it is (returns 0). Times are absolute seconds.
std::size_t deskewScan(LabeledCloud& cloud, const Vector6d& velocity, double reference_time);

/// Deskewing along a stream of scans: picks each scan's motion from what came before it (the
/// wheel increment into the scan, or the last tracked increment) and applies it.
class StreamDeskewer {
 public:
  explicit StreamDeskewer(DeskewConfig config) : config_(config) {}
  /// Deskews the scan at `stamp` (its reference time) in place; returns the body-frame velocity
  /// used, nullopt when the scan was left as it is (no per-point times, no motion known yet, a
  /// gap in the recording, deskewing off). With `gyro` covering the scan (an IMU stream), the
  /// rotation is the measured one and only the translation comes from the increment.
  std::optional<Vector6d> apply(LabeledCloud& cloud, double stamp,
                                const std::optional<Eigen::Isometry3d>& wheel_increment,
                                const GyroAttitude* gyro = nullptr);
  /// The tracked increment (previous scan ← this scan) of the scan just given to apply().
  void tracked(const Eigen::Isometry3d& T_prev_curr);

 private:
  std::optional<Vector6d> applyGyro(LabeledCloud& cloud, double stamp, std::optional<double> before,
                                    const std::optional<Eigen::Isometry3d>& wheel_increment,
                                    const GyroAttitude& gyro) const;
  DeskewConfig config_;
  std::optional<double> prev_stamp_, stamp_;
  std::optional<Eigen::Isometry3d> last_increment_;  ///< into the previous scan
  std::optional<Eigen::Isometry3d> pending_increment_;
  std::optional<double> last_increment_dt_;
};

}  // namespace hazmap
