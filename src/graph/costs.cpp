#include "hazmap/graph/costs.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "hazmap/core/error.hpp"

namespace hazmap {

PoseGraphCost parsePoseGraphCost(const std::string& name, const std::string& where) {
  if (name == "geodesic") return PoseGraphCost::Geodesic;
  if (name == "chordal") return PoseGraphCost::Chordal;
  fail(where, "unknown cost '" + name + "' (expected geodesic or chordal)");
}

const char* toString(PoseGraphCost cost) {
  return cost == PoseGraphCost::Chordal ? "chordal" : "geodesic";
}

ChordalWeights chordalWeights(const PoseGraphEdge& edge, int dimension) {
  const Matrix6d info = informationLeftToRight(edge.T_from_to, edge.information);
  ChordalWeights w;
  if (dimension == 2) {
    const Eigen::Matrix2d tt = info.topLeftCorner<2, 2>();
    w.tau = 2.0 / tt.inverse().trace();
    w.kappa = info(5, 5);
  } else {
    w.tau = 3.0 / info.topLeftCorner<3, 3>().inverse().trace();
    w.kappa = 3.0 / (2.0 * info.bottomRightCorner<3, 3>().inverse().trace());
  }
  return w;
}

Vector6d geodesicError(const PoseGraph& graph, const PoseGraphEdge& edge) {
  const Eigen::Isometry3d E =
      edge.T_from_to.inverse() * graph.poses[edge.from].inverse() * graph.poses[edge.to];
  Vector6d e = Vector6d::Zero();
  if (graph.dimension == 2) {
    e(0) = E.translation().x();
    e(1) = E.translation().y();
    e(5) = yawOf(E);
  } else {
    e.head<3>() = E.translation();
    e.tail<3>() = so3Log(E.linear());
  }
  return e;
}

bool isMixtureEdge(const PoseGraphEdge& edge, int dimension) {
  return edge.alt_weight > 0.0 && edge.alt_weight < 1.0 && dimension == 3;
}

MixtureOffsets mixtureOffsets(const PoseGraphEdge& edge) {
  // det Ω is the same for left and right perturbation (det Ad = 1).
  const double g_t = -std::log(edge.information.determinant()) - 2.0 * std::log(1.0 - edge.alt_weight);
  const double g_a = -std::log(edge.alt_information.determinant()) - 2.0 * std::log(edge.alt_weight);
  const double low = std::min(g_t, g_a);
  return {g_t - low, g_a - low};
}

namespace {

/// The two components' costs eᵀΩ_k e + γ_k of a mixture edge at error e (measurement frame).
std::pair<double, double> mixtureCosts(const PoseGraphEdge& edge, const Vector6d& e) {
  const MixtureOffsets g = mixtureOffsets(edge);
  const Matrix6d tight = informationLeftToRight(edge.T_from_to, edge.information);
  const Matrix6d wide = informationLeftToRight(edge.T_from_to, edge.alt_information);
  return {e.dot(tight * e) + g.tight, e.dot(wide * e) + g.alternative};
}

}  // namespace

int mixtureSelection(const PoseGraph& graph, const PoseGraphEdge& edge) {
  if (!isMixtureEdge(edge, graph.dimension)) return 0;
  const auto [tight, wide] = mixtureCosts(edge, geodesicError(graph, edge) - biasOffset(graph, edge));
  return wide < tight ? 1 : 0;
}

Vector6d biasOffset(const PoseGraph& graph, const PoseGraphEdge& edge) {
  if (!graph.hasBias(edge)) return Vector6d::Zero();
  return adjoint(edge.T_from_to.inverse()) * edge.bias_map * graph.biases[static_cast<std::size_t>(edge.bias)].value;
}

double biasPriorCost(const PoseGraph& graph) {
  double sum = 0.0;
  for (const EdgeBias& b : graph.biases) sum += b.value.dot(b.information * b.value);
  return sum;
}

double geodesicEdgeCost(const PoseGraph& graph, const PoseGraphEdge& edge) {
  const Vector6d e = geodesicError(graph, edge) - biasOffset(graph, edge);
  if (isMixtureEdge(edge, graph.dimension)) {
    const auto [tight, wide] = mixtureCosts(edge, e);
    return std::min(tight, wide);
  }
  const Matrix6d info = informationLeftToRight(edge.T_from_to, edge.information);
  if (graph.dimension == 2) {
    double c = 0.0;
    for (int r = 0; r < 3; ++r)
      for (int s = 0; s < 3; ++s)
        c += e(kPlanarIndex[r]) * info(kPlanarIndex[r], kPlanarIndex[s]) * e(kPlanarIndex[s]);
    return c;
  }
  return e.dot(info * e);
}

double chordalEdgeCost(const PoseGraph& graph, const PoseGraphEdge& edge) {
  const ChordalWeights w = chordalWeights(edge, graph.dimension);
  const Eigen::Isometry3d& Ti = graph.poses[edge.from];
  const Eigen::Isometry3d& Tj = graph.poses[edge.to];
  const Eigen::Matrix3d dR = Tj.linear() - Ti.linear() * edge.T_from_to.linear();
  const Eigen::Vector3d dt =
      Tj.translation() - Ti.translation() - Ti.linear() * edge.T_from_to.translation();
  if (graph.dimension == 2)
    return w.kappa * dR.topLeftCorner<2, 2>().squaredNorm() + w.tau * dt.head<2>().squaredNorm();
  return w.kappa * dR.squaredNorm() + w.tau * dt.squaredNorm();
}

double geodesicCost(const PoseGraph& graph) {
  double sum = 0.0;
  for (const auto& e : graph.edges) sum += geodesicEdgeCost(graph, e);
  return sum + biasPriorCost(graph);
}

double chordalCost(const PoseGraph& graph) {
  double sum = 0.0;
  for (const auto& e : graph.edges) sum += chordalEdgeCost(graph, e);
  return sum;
}

double poseGraphCost(const PoseGraph& graph, PoseGraphCost cost) {
  return cost == PoseGraphCost::Chordal ? chordalCost(graph) : geodesicCost(graph);
}

}  // namespace hazmap
