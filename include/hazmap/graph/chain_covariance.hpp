#pragma once
// The covariance a pose graph's odometry chain gives the relative pose of two of its nodes:
// the increments' covariances composed along the path (first order, independent increments).
// Used to gate loops honestly (loop/consistency.hpp, innovationGate): the test is as strict as
// the calibrated edges say the estimate is, not as a hand-set drift rate.
#include <Eigen/Geometry>
#include <algorithm>
#include <cstddef>
#include <utility>
#include <vector>

#include "hazmap/core/se3.hpp"

namespace hazmap {

/// `poses` = T_world_node for every node; `step_covariance[k]` = covariance of the increment
/// k−1 → k (left perturbation, translation first, in frame k−1; entry 0 unused). Returns the
/// covariance of T_from_to in frame `from` (left perturbation): Σ = Σ_k Ad(T_from_k) Σ_k+1 Ad(T_from_k)ᵀ.
/// from > to gives the covariance of T_to_from's inverse expressed in `from`. Throws on indices out
/// of range.
Matrix6d chainCovariance(const std::vector<Eigen::Isometry3d>& poses, const std::vector<Matrix6d>& step_covariance,
                         std::size_t from, std::size_t to);

/// The same over steps from anywhere: `step(k)` returns a pointer to step k's covariance, or null
/// where it is zero, asked for in ascending k. Throws on a node index out of range.
template <typename StepAt>
Matrix6d chainCovariance(const std::vector<Eigen::Isometry3d>& poses, std::size_t from, std::size_t to, StepAt step);

/// Steps that are zero but for a few: (k, covariance of the increment k−1 → k) for the non-zero
/// ones, ascending k (the dead-reckoned shares of a run's increments: pipeline/map_anchors).
using SparseSteps = std::vector<std::pair<std::size_t, Matrix6d>>;
/// The same sum over sparse steps; the zero terms are skipped, so it equals the dense one bit for bit.
Matrix6d chainCovariance(const std::vector<Eigen::Isometry3d>& poses, const SparseSteps& steps, std::size_t from,
                         std::size_t to);

namespace chain_detail {
void checkNodes(const std::vector<Eigen::Isometry3d>& poses, std::size_t from, std::size_t to);
}

// Σ = Σ_k Ad(T_a_k) Σ_k+1 Ad(T_a_k)ᵀ for k in [a, b); a null step is zero (adding Ad·0·Adᵀ
// changes no bit of the sum).
template <typename StepAt>
Matrix6d chainCovariance(const std::vector<Eigen::Isometry3d>& poses, std::size_t from, std::size_t to, StepAt step) {
  chain_detail::checkNodes(poses, from, to);
  const std::size_t a = std::min(from, to), b = std::max(from, to);
  Matrix6d sigma = Matrix6d::Zero();
  Eigen::Isometry3d T_a_k = Eigen::Isometry3d::Identity();
  for (std::size_t k = a; k < b; ++k) {
    if (const Matrix6d* s = step(k + 1)) {
      const Matrix6d Ad = adjoint(T_a_k);
      sigma += Ad * *s * Ad.transpose();
    }
    T_a_k = T_a_k * (poses[k].inverse() * poses[k + 1]);
  }
  if (from <= to) return sigma;
  // T_to_from = T_from_to⁻¹: a left perturbation in `a` becomes one in `b` through Ad(T_b_a).
  const Matrix6d Ad = adjoint(T_a_k.inverse());
  return Ad * sigma * Ad.transpose();
}

}  // namespace hazmap
