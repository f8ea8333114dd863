// Gravity-direction priors of pose-graph nodes (include/hazmap/graph/gravity_prior.hpp).
#include "hazmap/graph/gravity_prior.hpp"

#include <cmath>

#include "graph/gravity_residual.hpp"
#include "hazmap/core/error.hpp"

namespace hazmap {

int PoseGraph::addGravityPrior(int node, const Eigen::Vector3d& down, double sigma) {
  const std::string where = "pose graph";
  if (node < 0 || node >= numNodes())
    fail(where, "gravity prior on node " + std::to_string(node) + " out of range (" + std::to_string(numNodes()) + " nodes)");
  if (!down.allFinite() || std::abs(down.norm() - 1.0) > 1e-3)
    fail(where, "gravity prior on node " + std::to_string(node) + ": direction is not a finite unit vector");
  if (!(sigma > 0.0) || !std::isfinite(sigma))
    fail(where, "gravity prior on node " + std::to_string(node) + ": sigma must be finite and > 0");
  gravity_priors.push_back({node, down.normalized(), sigma});
  return static_cast<int>(gravity_priors.size()) - 1;
}

Eigen::Vector2d gravityResidual(const GravityPrior& prior, const Eigen::Matrix3d& R_world_node,
                                const Eigen::Vector3d& gravity_world) {
  return graph_detail::GravityPriorCost(prior.down, prior.sigma).residual(R_world_node, gravity_world);
}

double gravityPriorCost(const PoseGraph& graph) {
  double cost = 0.0;
  for (const auto& p : graph.gravity_priors)
    cost += gravityResidual(p, graph.poses.at(p.node).linear(), graph.gravity_world).squaredNorm();
  return cost;
}

Eigen::Vector3d meanGravityWorld(const PoseGraph& graph) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : graph.gravity_priors) sum += graph.poses.at(p.node).linear() * p.down / (p.sigma * p.sigma);
  return sum.norm() > 0.0 ? Eigen::Vector3d(sum.normalized()) : graph.gravity_world;
}

}  // namespace hazmap
