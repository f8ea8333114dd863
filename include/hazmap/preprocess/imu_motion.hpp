#pragma once
// The sensor's rotation measured by its gyro (Scan::imu): for deskewing a scan with the measured
// rotation instead of a constant velocity, and for the rotation of the next scan's initial guess.
// The gyro's bias is estimated online against the rotations the registration verified.
#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/io/imu.hpp"

namespace hazmap {

/// The sensor's attitude over a span of gyro samples (time order, e.g. Scan::imu), relative to the
/// first sample: the rate between two samples is their mean minus the bias, constant in between.
class GyroAttitude {
 public:
  GyroAttitude(const std::vector<ImuSample>& samples, const Eigen::Vector3d& bias);
  bool empty() const { return times_.size() < 2; }
  /// R_first_t; t is clamped to the samples' span.
  Eigen::Matrix3d at(double t) const;
  /// R_t0_t1: vectors of the sensor frame at t1 into the frame at t0.
  Eigen::Matrix3d between(double t0, double t1) const { return at(t0).transpose() * at(t1); }
  bool covers(double t0, double t1) const { return !empty() && times_.front() <= t0 && times_.back() >= t1; }

 private:
  std::vector<double> times_;
  std::vector<Eigen::Vector3d> rates_;  ///< over [times_[k], times_[k+1]]
  std::vector<Eigen::Matrix3d> attitude_;
};

/// Moves every point, measured at cloud.timestamps[i], into the sensor frame at `reference_time`:
/// rotated by the gyro's attitude, shifted by the constant body-frame `linear_velocity` (m/s).
/// Returns the number of points moved (0 without timestamps or when `attitude` does not cover them).
std::size_t deskewScanWithGyro(LabeledCloud& cloud, const GyroAttitude& attitude,
                               const Eigen::Vector3d& linear_velocity, double reference_time);

/// The gyro's bias, estimated from the rotations tracking verified: the gyro's rotation over an
/// increment against the registered one, the difference per second averaged with a small gain.
class GyroBiasEstimator {
 public:
  const Eigen::Vector3d& bias() const { return bias_; }
  /// `R_gyro` integrated with bias() over `dt` s, `R_tracked` the verified increment's rotation.
  /// A difference above 1 °/s or 3° is a registration's error or a slip, not a bias: ignored.
  void update(const Eigen::Matrix3d& R_gyro, const Eigen::Matrix3d& R_tracked, double dt);

 private:
  Eigen::Vector3d bias_ = Eigen::Vector3d::Zero();
};

/// A stream of scans with their IMU samples (Scan::imu): per scan the gyro's attitude over it (for
/// deskewing) and its rotation since the previous scan (the guess's), with the bias estimated
/// from the increments tracking verified. Without samples it gives nothing (as without an IMU).
class ImuStreamMotion {
 public:
  struct Motion {
    std::optional<GyroAttitude> attitude;     ///< when the scan has samples
    std::optional<Eigen::Matrix3d> rotation;  ///< previous ← this scan, when they cover the step
    const GyroAttitude* attitudePtr() const { return attitude ? &*attitude : nullptr; }
  };
  /// The scan at `stamp` with its samples `imu` (time order).
  Motion next(const std::vector<ImuSample>& imu, double stamp);
  /// The increment tracking verified for that scan (previous ← this), or nullopt (not verified).
  void tracked(const std::optional<Eigen::Matrix3d>& verified_rotation);
  const Eigen::Vector3d& bias() const { return bias_.bias(); }

 private:
  GyroBiasEstimator bias_;
  std::optional<double> last_stamp_;
  std::optional<Eigen::Matrix3d> pending_;
  double pending_dt_ = 0.0;
};

}  // namespace hazmap
