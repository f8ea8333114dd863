#include "hazmap/graph/chain_covariance.hpp"

#include <algorithm>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {

// Σ = Σ_k Ad(T_a_k) Σ_k+1 Ad(T_a_k)ᵀ for k in [a, b); `next(k + 1)` is step k + 1's covariance or
// null where it is zero (adding Ad·0·Adᵀ changes no bit of the sum).
template <typename StepAt>
Matrix6d chain(const std::vector<Eigen::Isometry3d>& poses, std::size_t from, std::size_t to, StepAt step) {
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

}  // namespace

Matrix6d chainCovariance(const std::vector<Eigen::Isometry3d>& poses, const std::vector<Matrix6d>& step_covariance,
                         std::size_t from, std::size_t to) {
  if (std::max(from, to) >= poses.size() || std::max(from, to) >= step_covariance.size())
    fail("chainCovariance", "node index out of range");
  return chain(poses, from, to, [&](std::size_t k) { return &step_covariance[k]; });
}

Matrix6d chainCovariance(const std::vector<Eigen::Isometry3d>& poses, const SparseSteps& steps, std::size_t from,
                         std::size_t to) {
  if (std::max(from, to) >= poses.size()) fail("chainCovariance", "node index out of range");
  // Steps are asked for in ascending order: walk the list alongside.
  auto next = std::lower_bound(steps.begin(), steps.end(), std::min(from, to) + 1,
                               [](const auto& s, std::size_t k) { return s.first < k; });
  return chain(poses, from, to, [&](std::size_t k) -> const Matrix6d* {
    if (next == steps.end() || next->first != k) return nullptr;
    return &(next++)->second;
  });
}

}  // namespace hazmap
