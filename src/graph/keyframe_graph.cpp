#include "hazmap/graph/keyframe_graph.hpp"

#include <Eigen/Cholesky>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"

namespace hazmap {

namespace {

Matrix6d covarianceOf(const Matrix6d& information) {
  Matrix6d sigma = information.ldlt().solve(Matrix6d::Identity());
  return 0.5 * (sigma + sigma.transpose());
}

// The odometry edge into each node (`into[k]` joins k−1 → k), or false when the chain is not one.
bool odometryChain(const PoseGraph& graph, std::vector<const PoseGraphEdge*>& into) {
  into.assign(graph.poses.size(), nullptr);
  for (const PoseGraphEdge& e : graph.edges) {
    if (e.kind != EdgeKind::Odometry) continue;
    if (e.to != e.from + 1 || into[static_cast<std::size_t>(e.to)]) return false;
    into[static_cast<std::size_t>(e.to)] = &e;
  }
  return true;
}

// The chain a → b folded: the increments composed, Σ = Σ_k Ad(T_a_k) Σ_k+1 Ad(T_a_k)ᵀ (left
// perturbation in a, as graph/chain_covariance.hpp), its inverse the edge's information.
std::optional<PoseGraphEdge> foldedChain(const std::vector<const PoseGraphEdge*>& into, int a, int b) {
  PoseGraphEdge folded;
  Matrix6d sigma = Matrix6d::Zero();
  for (int k = a + 1; k <= b; ++k) {
    const PoseGraphEdge* e = into[static_cast<std::size_t>(k)];
    if (!e) return std::nullopt;
    const Matrix6d Ad = adjoint(folded.T_from_to);
    sigma += Ad * covarianceOf(e->information) * Ad.transpose();
    folded.T_from_to = normalized(folded.T_from_to * e->T_from_to);
  }
  folded.information = covarianceOf(sigma);
  return folded;
}

}  // namespace

std::optional<PoseGraph> keyframeGraph(const PoseGraph& graph, const std::vector<int>& kept) {
  if (kept.empty() || kept.front() != graph.fixed_node) return std::nullopt;
  std::vector<int> index(graph.poses.size(), -1);  // graph node → kept node
  PoseGraph out;
  out.dimension = graph.dimension;
  out.gravity_world = graph.gravity_world;
  for (std::size_t j = 0; j < kept.size(); ++j) {
    const int n = kept[j];
    if (n < 0 || n >= graph.numNodes() || (j > 0 && n <= kept[j - 1])) return std::nullopt;
    const auto node = static_cast<std::size_t>(n);
    index[node] = out.addNode(graph.poses[node], node < graph.ids.size() ? graph.ids[node] : n);
  }
  std::vector<const PoseGraphEdge*> into;
  if (!odometryChain(graph, into)) return std::nullopt;
  for (std::size_t j = 1; j < kept.size(); ++j) {
    const std::optional<PoseGraphEdge> chain = foldedChain(into, kept[j - 1], kept[j]);
    if (!chain) return std::nullopt;
    out.addEdge(static_cast<int>(j - 1), static_cast<int>(j), chain->T_from_to, chain->information);
  }
  for (const PoseGraphEdge& e : graph.edges) {
    if (e.kind == EdgeKind::Odometry) continue;
    const int from = index[static_cast<std::size_t>(e.from)], to = index[static_cast<std::size_t>(e.to)];
    if (from < 0 || to < 0) return std::nullopt;
    out.addEdge(from, to, e.T_from_to, e.information, e.kind);
  }
  for (const GravityPrior& p : graph.gravity_priors) {
    const int node = index[static_cast<std::size_t>(p.node)];
    if (node < 0) return std::nullopt;
    out.gravity_priors.push_back({node, p.down, p.sigma});
  }
  return out;
}

void applyKeyframeSolution(PoseGraph& graph, const std::vector<int>& kept, const PoseGraph& solved) {
  if (solved.poses.size() != kept.size())
    fail("pose graph", "a keyframe graph's solution has " + std::to_string(solved.poses.size()) + " poses for " +
                           std::to_string(kept.size()) + " keyframes");
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();  // of the kept node before
  std::size_t j = 0;
  for (std::size_t n = 0; n < graph.poses.size(); ++n) {
    if (j < kept.size() && static_cast<std::size_t>(kept[j]) == n) {
      correction = solved.poses[j] * graph.poses[n].inverse();
      graph.poses[n] = solved.poses[j++];
    } else if (j > 0) {
      graph.poses[n] = normalized(correction * graph.poses[n]);
    }
  }
  graph.gravity_world = solved.gravity_world;
}

}  // namespace hazmap
