#pragma once
// Property-aware ICP (paper section IV, eq. 2) with pose covariance. Plain ICP is the same code
// with use_classes = false (α = 0 and one search radius for every point).
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/core/se3.hpp"

namespace hazmap {

enum class IcpMetric { PointToPoint, PointToPlane };

struct RegistrationConfig {
  bool use_classes = true;                ///< false = conventional ICP
  IcpMetric metric = IcpMetric::PointToPlane;
  double max_correspondence_distance = 1.0;  ///< m, for unlabelled points
  int max_iterations = 50;
  // (the registration stage adds its further documented settings here)
};

struct RegistrationResult {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();  ///< target ← source
  Matrix6d covariance = Matrix6d::Identity();  ///< translation-first (see core/se3.hpp)
  double fitness = 0.0;       ///< fraction of source points with a correspondence
  double inlier_rmse = 0.0;   ///< m
  int iterations = 0;
  bool converged = false;
  std::vector<Vector6d> degenerate_directions;  ///< unit tangent directions, translation-first
  std::string reason;  ///< why it did not converge (empty when converged)
};

/// Aligns `source` to `target` starting from `initial_guess` (target ← source).
RegistrationResult registerClouds(const LabeledCloud& source, const LabeledCloud& target,
                                  const Eigen::Isometry3d& initial_guess, const ClassTable& classes,
                                  const RegistrationConfig& config = {});

}  // namespace hazmap
