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

double geodesicEdgeCost(const PoseGraph& graph, const PoseGraphEdge& edge) {
  const Vector6d e = geodesicError(graph, edge);
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
  return sum;
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
