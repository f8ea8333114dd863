#include "hazmap/graph/chain_covariance.hpp"

#include <algorithm>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace chain_detail {

void checkNodes(const std::vector<Eigen::Isometry3d>& poses, std::size_t from, std::size_t to) {
  if (std::max(from, to) >= poses.size()) fail("chainCovariance", "node index out of range");
}

}  // namespace chain_detail

Matrix6d chainCovariance(const std::vector<Eigen::Isometry3d>& poses, const std::vector<Matrix6d>& step_covariance,
                         std::size_t from, std::size_t to) {
  if (std::max(from, to) >= step_covariance.size()) fail("chainCovariance", "node index out of range");
  return chainCovariance(poses, from, to, [&](std::size_t k) { return &step_covariance[k]; });
}

Matrix6d chainCovariance(const std::vector<Eigen::Isometry3d>& poses, const SparseSteps& steps, std::size_t from,
                         std::size_t to) {
  // Steps are asked for in ascending order: walk the list alongside.
  auto next = std::lower_bound(steps.begin(), steps.end(), std::min(from, to) + 1,
                               [](const auto& s, std::size_t k) { return s.first < k; });
  return chainCovariance(poses, from, to, [&](std::size_t k) -> const Matrix6d* {
    if (next == steps.end() || next->first != k) return nullptr;
    return &(next++)->second;
  });
}

}  // namespace hazmap
