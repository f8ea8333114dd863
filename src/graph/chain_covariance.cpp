#include "hazmap/graph/chain_covariance.hpp"

#include <algorithm>

#include "hazmap/core/error.hpp"

namespace hazmap {

Matrix6d chainCovariance(const std::vector<Eigen::Isometry3d>& poses, const std::vector<Matrix6d>& step_covariance,
                         std::size_t from, std::size_t to) {
  if (std::max(from, to) >= poses.size() || std::max(from, to) >= step_covariance.size())
    fail("chainCovariance", "node index out of range");
  const std::size_t a = std::min(from, to), b = std::max(from, to);
  Matrix6d sigma = Matrix6d::Zero();
  Eigen::Isometry3d T_a_k = Eigen::Isometry3d::Identity();
  for (std::size_t k = a; k < b; ++k) {
    const Matrix6d Ad = adjoint(T_a_k);
    sigma += Ad * step_covariance[k + 1] * Ad.transpose();
    T_a_k = T_a_k * (poses[k].inverse() * poses[k + 1]);
  }
  if (from <= to) return sigma;
  // T_to_from = T_from_to⁻¹: a left perturbation in `a` becomes one in `b` through Ad(T_b_a).
  const Matrix6d Ad = adjoint(T_a_k.inverse());
  return Ad * sigma * Ad.transpose();
}

}  // namespace hazmap
