#include "hazmap/graph/graph_union.hpp"

#include <algorithm>

#include "hazmap/core/error.hpp"

namespace hazmap {

int appendGraph(PoseGraph& into, const PoseGraph& graph, const Eigen::Isometry3d& T_into_graph) {
  if (into.dimension != graph.dimension)
    fail("pose graph", "cannot join a " + std::to_string(graph.dimension) + "-D graph to a " +
                           std::to_string(into.dimension) + "-D one");
  const int offset = into.numNodes();
  std::int64_t next_id = 0;
  for (std::int64_t id : into.ids) next_id = std::max(next_id, id + 1);
  if (into.ids.size() < into.poses.size()) next_id = std::max<std::int64_t>(next_id, offset);
  for (const auto& pose : graph.poses) into.addNode(normalized(T_into_graph * pose), next_id++);
  for (const auto& e : graph.edges) into.addEdge(e.from + offset, e.to + offset, e.T_from_to, e.information, e.kind);
  for (const auto& g : graph.gravity_priors) into.addGravityPrior(g.node + offset, g.down, g.sigma);
  return offset;
}

}  // namespace hazmap
