#include "hazmap/graph/pose_graph.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <deque>
#include <numeric>
#include <string>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {

Eigen::Matrix3d planarBlock(const Matrix6d& m) {
  Eigen::Matrix3d out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out(r, c) = m(kPlanarIndex[r], kPlanarIndex[c]);
  return out;
}

template <typename M>
bool symmetricPositiveDefinite(const M& m) {
  if (!m.allFinite()) return false;
  const double scale = m.cwiseAbs().maxCoeff();
  if (!(scale > 0.0)) return false;
  if ((m - m.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) return false;
  Eigen::LLT<M> llt(m);
  if (llt.info() != Eigen::Success) return false;
  // Reject numerically singular matrices too (a zero-information direction).
  const M L = llt.matrixL();
  return L.diagonal().minCoeff() > 1e-12 * std::sqrt(scale);
}

}  // namespace

int PoseGraph::addNode(const Eigen::Isometry3d& T_world_node, std::int64_t id) {
  if (!isFinite(T_world_node)) fail("pose graph", "node " + std::to_string(poses.size()) +
                                                      " has a non-finite pose");
  poses.push_back(dimension == 2 ? planarized(T_world_node) : T_world_node);
  ids.push_back(id < 0 ? static_cast<std::int64_t>(poses.size() - 1) : id);
  return static_cast<int>(poses.size() - 1);
}

int PoseGraph::addEdge(int from, int to, const Eigen::Isometry3d& T_from_to,
                       const Matrix6d& information, EdgeKind kind) {
  const auto where = "pose graph edge " + std::to_string(from) + "->" + std::to_string(to);
  if (from < 0 || to < 0 || from >= numNodes() || to >= numNodes())
    fail(where, "node index out of range (graph has " + std::to_string(numNodes()) + " nodes)");
  if (from == to) fail(where, "an edge must join two different nodes");
  if (!isFinite(T_from_to)) fail(where, "non-finite relative pose");
  const bool ok = dimension == 2 ? symmetricPositiveDefinite(planarBlock(information))
                                 : symmetricPositiveDefinite(information);
  if (!ok) fail(where, "information matrix is not symmetric positive definite");
  PoseGraphEdge e;
  e.from = from;
  e.to = to;
  e.T_from_to = dimension == 2 ? planarized(T_from_to) : T_from_to;
  e.information = information;
  e.kind = kind;
  edges.push_back(e);
  return static_cast<int>(edges.size() - 1);
}

int PoseGraph::numLoopEdges() const {
  int n = 0;
  for (const auto& e : edges) n += e.kind == EdgeKind::Loop;
  return n;
}

std::vector<int> connectedComponents(const PoseGraph& graph, int* num_components) {
  const int n = graph.numNodes();
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& e : graph.edges) {
    const int a = find(e.from), b = find(e.to);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::vector<int> label(n, -1), component(n);
  int count = 0;
  for (int i = 0; i < n; ++i) {
    const int root = find(i);
    if (label[root] < 0) label[root] = count++;
    component[i] = label[root];
  }
  if (num_components) *num_components = count;
  return component;
}

void checkOptimisable(const PoseGraph& graph, const std::string& where) {
  if (graph.dimension != 2 && graph.dimension != 3)
    fail(where, "dimension must be 2 or 3, not " + std::to_string(graph.dimension));
  if (graph.poses.empty()) fail(where, "the graph has no nodes");
  if (graph.ids.size() != graph.poses.size()) fail(where, "ids and poses differ in length");
  if (graph.fixed_node < 0 || graph.fixed_node >= graph.numNodes())
    fail(where, "fixed node index " + std::to_string(graph.fixed_node) + " out of range");
  for (int i = 0; i < graph.numNodes(); ++i)
    if (!isFinite(graph.poses[i]))
      fail(where, "node " + std::to_string(graph.ids[i]) + " has a non-finite pose");
  for (const auto& e : graph.edges)
    if (e.from < 0 || e.to < 0 || e.from >= graph.numNodes() || e.to >= graph.numNodes() ||
        e.from == e.to)
      fail(where, "edge with invalid node indices " + std::to_string(e.from) + "->" +
                      std::to_string(e.to));
  int components = 0;
  const auto comp = connectedComponents(graph, &components);
  if (components > 1) {
    const int fixed_comp = comp[graph.fixed_node];
    int outside = 0, example = -1;
    for (int i = 0; i < graph.numNodes(); ++i)
      if (comp[i] != fixed_comp) {
        ++outside;
        if (example < 0) example = i;
      }
    fail(where, "the graph is disconnected: " + std::to_string(components) + " components, " +
                    std::to_string(outside) + " nodes (e.g. id " +
                    std::to_string(graph.ids[example]) + ") not connected to the fixed node id " +
                    std::to_string(graph.ids[graph.fixed_node]));
  }
}

int initialiseFromOdometry(PoseGraph& graph) {
  const int n = graph.numNodes();
  if (n == 0) return 0;
  std::vector<std::vector<int>> adjacency(n);
  for (int k = 0; k < graph.numEdges(); ++k) {
    adjacency[graph.edges[k].from].push_back(k);
    adjacency[graph.edges[k].to].push_back(k);
  }
  std::vector<char> reached(n, 0);
  reached[graph.fixed_node] = 1;
  int count = 1;
  // Pass 0 spreads along odometry edges only; pass 1 lets loop edges reach what is left.
  for (int pass = 0; pass < 2; ++pass) {
    std::deque<int> queue;
    for (int i = 0; i < n; ++i)
      if (reached[i]) queue.push_back(i);
    while (!queue.empty()) {
      const int i = queue.front();
      queue.pop_front();
      for (int k : adjacency[i]) {
        const auto& e = graph.edges[k];
        if (pass == 0 && e.kind != EdgeKind::Odometry) continue;
        const int other = e.from == i ? e.to : e.from;
        if (reached[other]) continue;
        graph.poses[other] = normalized(e.from == i ? graph.poses[i] * e.T_from_to
                                                    : graph.poses[i] * e.T_from_to.inverse());
        if (graph.dimension == 2) graph.poses[other] = planarized(graph.poses[other]);
        reached[other] = 1;
        ++count;
        queue.push_back(other);
      }
    }
  }
  return count;
}

Matrix6d informationLeftToRight(const Eigen::Isometry3d& T_from_to, const Matrix6d& left) {
  // ξ_left = Ad(T) ξ_right  ⇒  ξ_leftᵀ Ω_left ξ_left = ξ_rightᵀ (Adᵀ Ω_left Ad) ξ_right.
  const Matrix6d A = adjoint(T_from_to);
  Matrix6d right = A.transpose() * left * A;
  return 0.5 * (right + right.transpose());
}

Matrix6d informationRightToLeft(const Eigen::Isometry3d& T_from_to, const Matrix6d& right) {
  const Matrix6d A_inv = adjoint(T_from_to.inverse());  // Ad(T)⁻¹ = Ad(T⁻¹)
  Matrix6d left = A_inv.transpose() * right * A_inv;
  return 0.5 * (left + left.transpose());
}

Eigen::Isometry3d planarized(const Eigen::Isometry3d& T) {
  return fromXyYaw(T.translation().x(), T.translation().y(), yawOf(T));
}

}  // namespace hazmap
