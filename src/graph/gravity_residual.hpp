#pragma once
// Ceres residual of the gravity-direction prior (graph/gravity_prior.hpp) with analytic
// Jacobians: parameter blocks are the node's 12-double pose [t | R] (PoseManifold3, tangent
// δ = [δt; δφ], R ← R·Exp(δφ)) and the world's down direction g (3 doubles on a sphere).
#include <ceres/ceres.h>

#include <Eigen/Core>

#include "hazmap/core/se3.hpp"

namespace hazmap::graph_detail {

class GravityPriorCost final : public ceres::SizedCostFunction<2, 12, 3> {
 public:
  /// `down`: the measured unit direction in the node's frame; `sigma`: rad per axis.
  GravityPriorCost(const Eigen::Vector3d& down, double sigma) {
    const Eigen::Vector3d b1 = down.unitOrthogonal();
    Bt_.row(0) = b1.transpose() / sigma;
    Bt_.row(1) = down.cross(b1).transpose() / sigma;
  }

  Eigen::Vector2d residual(const Eigen::Matrix3d& R, const Eigen::Vector3d& g) const { return Bt_ * (R.transpose() * g); }

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    Eigen::Map<const Eigen::Matrix3d> R(p[0] + 3);
    Eigen::Map<const Eigen::Vector3d> g(p[1]);
    const Eigen::Vector3d predicted = R.transpose() * g;  // world down seen from the node
    Eigen::Map<Eigen::Vector2d>{residuals} = Bt_ * predicted;
    if (!jacobians) return true;
    if (jacobians[0]) {  // Exp(δφ)ᵀ Rᵀ g ≈ p + [p]× δφ
      Eigen::Map<Eigen::Matrix<double, 2, 12, Eigen::RowMajor>> J(jacobians[0]);
      J.setZero();
      J.block<2, 3>(0, 3) = Bt_ * hat(predicted);
    }
    if (jacobians[1]) {
      Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> J(jacobians[1]);
      J = Bt_ * R.transpose();
    }
    return true;
  }

 private:
  Eigen::Matrix<double, 2, 3> Bt_;  // Bᵀ / σ
};

}  // namespace hazmap::graph_detail
