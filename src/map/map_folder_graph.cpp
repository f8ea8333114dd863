// graph_extras.json of a map folder (include/hazmap/map/map_folder.hpp): what graph.g2o cannot
// say, so a merge solves each map's graph with the costs its run used: which edges are loops
// (robust loss) or map anchors, and the gravity priors on roll and pitch.
#include <nlohmann/json.hpp>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/map/map_folder.hpp"
#include "map/map_folder_json.hpp"

namespace hazmap {

namespace fs = std::filesystem;

namespace {

nlohmann::json xyz(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

Eigen::Vector3d xyzFrom(const nlohmann::json& j) {
  if (!j.is_array() || j.size() != 3) throw std::invalid_argument("expected [x, y, z]");
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

void setKinds(const nlohmann::json& list, EdgeKind kind, PoseGraph& graph) {
  for (const auto& e : list) {
    const auto i = e.get<std::size_t>();
    if (i >= graph.edges.size())
      throw std::invalid_argument("edge " + std::to_string(i) + " beyond graph.g2o's " + std::to_string(graph.edges.size()));
    graph.edges[i].kind = kind;
  }
}

}  // namespace

std::string writeGraphExtras(const fs::path& dir, const PoseGraph& graph) {
  nlohmann::json loops = nlohmann::json::array(), anchors = nlohmann::json::array();
  for (std::size_t i = 0; i < graph.edges.size(); ++i) {
    if (graph.edges[i].kind == EdgeKind::Loop) loops.push_back(i);
    if (graph.edges[i].kind == EdgeKind::MapAnchor) anchors.push_back(i);
  }
  nlohmann::json priors = nlohmann::json::array();
  for (const auto& p : graph.gravity_priors) priors.push_back({{"node", p.node}, {"down", xyz(p.down)}, {"sigma", p.sigma}});
  const nlohmann::json j = {{"edges", graph.edges.size()}, {"loop_edges", loops}, {"map_anchor_edges", anchors},
                            {"gravity_world", xyz(graph.gravity_world)}, {"gravity_priors", priors}};
  writeTextAtomically(dir / "graph_extras.json", j.dump() + "\n");
  return "graph_extras.json";
}

namespace map_folder_detail {

void readGraphExtras(const fs::path& path, PoseGraph& graph) {
  try {
    const nlohmann::json j = nlohmann::json::parse(readTextFile(path));
    if (j.at("edges").get<std::size_t>() != graph.edges.size())
      throw std::invalid_argument("describes " + std::to_string(j.at("edges").get<std::size_t>()) +
                                  " edges, graph.g2o has " + std::to_string(graph.edges.size()));
    setKinds(j.at("loop_edges"), EdgeKind::Loop, graph);
    setKinds(j.at("map_anchor_edges"), EdgeKind::MapAnchor, graph);
    graph.gravity_world = xyzFrom(j.at("gravity_world"));
    for (const auto& p : j.at("gravity_priors"))
      graph.addGravityPrior(p.at("node").get<int>(), xyzFrom(p.at("down")), p.at("sigma").get<double>());
  } catch (const Error& e) {
    fail(path.string(), e.what());
  } catch (const std::exception& e) {
    fail(path.string(), std::string("broken graph extras: ") + e.what());
  }
}

}  // namespace map_folder_detail

}  // namespace hazmap
