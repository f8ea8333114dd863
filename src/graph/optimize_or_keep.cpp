// The back end's guarded optimisation (issue 14): a failed solve never replaces the estimate.
#include <cmath>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/graph/costs.hpp"
#include "hazmap/graph/optimizer.hpp"

namespace hazmap {

PoseGraphReport optimizePoseGraphOrKeep(PoseGraph& graph, const PoseGraphConfig& config, std::string& failure) {
  const std::vector<Eigen::Isometry3d> before = graph.poses;
  failure.clear();
  PoseGraphReport report;
  try {
    report = optimizePoseGraph(graph, config);
    bool finite = std::isfinite(report.final_geodesic);
    for (const auto& p : graph.poses) finite = finite && isFinite(p);
    if (!finite) failure = "non-finite solution (" + report.message + ")";
    else if (report.final_geodesic > report.initial_geodesic * (1.0 + 1e-9) + 1e-12)
      failure = "cost increased (" + report.message + ")";
  } catch (const Error& e) {
    failure = e.what();
  }
  if (!failure.empty()) graph.poses = before;
  return report;
}

std::vector<std::size_t> edgesBeyond(const PoseGraph& graph, EdgeKind kind, double threshold) {
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < graph.edges.size(); ++i)
    if (graph.edges[i].kind == kind && !(geodesicEdgeCost(graph, graph.edges[i]) <= threshold)) out.push_back(i);
  return out;
}

}  // namespace hazmap
