#pragma once
// Failure detection of the odometry, shared by tracking (odometry.cpp) and the recovery of
// frames where tracking failed (odometry_recover.cpp).
#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <string>

#include "hazmap/registration/registration_target.hpp"

#include "hazmap/odometry/odometry.hpp"

namespace hazmap {

struct Odometry::Impl {
  std::unique_ptr<RegistrationTarget> previous;  ///< FrameToFrame: the last non-empty scan
  Eigen::Isometry3d previous_pose = Eigen::Isometry3d::Identity();  ///< its pose (world ← scan)
  Eigen::Isometry3d velocity = Eigen::Isometry3d::Identity();  ///< last increment
  bool has_velocity = false;
  bool velocity_verified = false;  ///< the last increment came from a verified registration
  /// Running mean of the inlier RMSE of tracked frames: how well a right answer fits here.
  double typical_rmse = 0.0;
};

/// Why ICP's answer cannot be used (empty when it can): did not converge (stopping at the
/// iteration limit is not a failure), fitness below min_fitness, or a correction of the start
/// larger than max_correction_*.
std::string registrationFailure(const RegistrationResult& r, const Eigen::Isometry3d& start,
                                const OdometryConfig& config);

/// The registration's weakest horizontal translation axis (unit, registration space) when its
/// Hessian eigenvalue, rotation marginalised, is below `ratio` × the strongest; else nothing.
std::optional<Eigen::Vector3d> weakHorizontalAxis(const RegistrationResult& r, double ratio);

}  // namespace hazmap
