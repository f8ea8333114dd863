// Placing the maps of a merge in the first map's frame and solving one graph
// (pipeline/merge_detail.hpp). Each later map is searched for among every keyframe placed before
// it, exactly as a run is in its prior (prior_search.hpp); once localised, each of its keyframes
// is verified against the placed keyframes nearest it, and the verified loops join its graph to
// theirs.
#include <fmt/format.h>

#include "hazmap/core/se3.hpp"
#include "hazmap/graph/graph_union.hpp"
#include "hazmap/graph/optimizer.hpp"
#include "pipeline/clock.hpp"
#include "pipeline/merge_detail.hpp"

namespace hazmap::pipeline_detail {

namespace {

// χ² 99 % bound for 6 degrees of freedom: a loop whose whitened error exceeds it after the solve
// disagrees with the rest of the evidence.
constexpr double kLoopChi2Bound = 16.81;

// Keyframe poses of a placed input (its `poses` at the keyframes' frames) and their graph nodes.
void keyframesOf(const MergeInput& in, std::size_t offset, std::vector<Eigen::Isometry3d>& poses,
                 std::vector<std::size_t>& nodes) {
  poses.clear();
  nodes.clear();
  for (const auto& k : in.map.keyframes()) {
    poses.push_back(in.poses.at(k.frame));
    nodes.push_back(offset + k.frame);
  }
}

// Every placed input's poses (and the index's keyframes) taken from the solved graph.
void takePoses(const PoseGraph& graph, std::vector<MergeInput>& inputs, const MergeReport& report, PriorIndex& index) {
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    if (!report.maps[i].placed) continue;
    for (std::size_t f = 0; f < inputs[i].poses.size(); ++f)
      inputs[i].poses[f] = graph.poses.at(report.maps[i].node_offset + f);
  }
  for (std::size_t k = 0; k < index.size(); ++k) index.setPose(k, graph.poses.at(index.tag(k)));
}

void solve(PoseGraph& graph, const SlamConfig& config, MergeReport& report) {
  std::string failure;
  optimizePoseGraphOrKeep(graph, config.graph, failure);
  if (!failure.empty()) report.optimisation_notes.push_back(failure);
}

// Searches input `in` among the keyframes of `index`; when localised, its verified loops.
std::vector<PriorEdge> placeOne(const PriorIndex& index, MergeInput& in, const ClassTable& classes,
                                const SlamConfig& config, MapPlacement& placement) {
  const auto t0 = Clock::now();
  PriorLocalisation& loc = placement.localisation;
  const RunKeyframes run = mapKeyframes(in.map, classes);
  searchPrior(index, run, in.poses, classes, config, loc);
  loc.search_seconds = secondsSince(t0);
  std::vector<PriorEdge> edges;
  if (loc.state == PriorState::Localised) {
    FramePoses moved = in.poses;
    for (auto& p : moved) p = normalized(loc.T_prior_run * p);
    edges = loopsToPrior(index, run, moved, classes, config, loc);
    if (placementConfirmed(edges, "the maps placed before it", loc))
      in.poses = std::move(moved);
    else
      edges.clear();
  } else {
    loc.state = PriorState::NeverLocalised;
  }
  // Attempts name the merged frame they were verified against, not the index's keyframe.
  for (auto* list : {&loc.search, &loc.loops})
    for (auto& a : *list) a.prior_keyframe = index.tag(a.prior_keyframe);
  loc.total_seconds = secondsSince(t0);
  return edges;
}

}  // namespace

PoseGraph placeMaps(std::vector<MergeInput>& inputs, const ClassTable& classes, const SlamConfig& config,
                    MergeReport& report) {
  report.maps.assign(inputs.size(), {});
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    report.maps[i].dir = inputs[i].map.dir();
    report.maps[i].frames = inputs[i].poses.size();
    report.maps[i].keyframes = inputs[i].map.keyframes().size();
  }
  PoseGraph graph = inputs[0].graph;
  graph.fixed_node = 0;
  report.maps[0].placed = true;
  report.maps[0].localisation.state = PriorState::Localised;
  PriorIndex index(config);
  std::vector<Eigen::Isometry3d> poses;
  std::vector<std::size_t> nodes;
  keyframesOf(inputs[0], 0, poses, nodes);
  index.add(inputs[0].map, poses, nodes, classes);
  for (std::size_t i = 1; i < inputs.size(); ++i) {
    index.prepare(classes, inputs[0].map.dir().string());
    MapPlacement& placement = report.maps[i];
    const std::vector<PriorEdge> edges = placeOne(index, inputs[i], classes, config, placement);
    if (edges.empty()) continue;
    placement.placed = true;
    placement.node_offset = static_cast<std::size_t>(appendGraph(graph, inputs[i].graph, placement.localisation.T_prior_run));
    for (const auto& e : edges)
      graph.addEdge(static_cast<int>(index.tag(e.prior_keyframe)), static_cast<int>(placement.node_offset + e.frame),
                    e.T_prior_frame, e.information, EdgeKind::Loop);
    placement.inter_session_loops = edges.size();
    report.inter_session_loops += edges.size();
    const std::size_t failures = report.optimisation_notes.size();
    solve(graph, config, report);
    placement.localisation.optimised = report.optimisation_notes.size() == failures;
    takePoses(graph, inputs, report, index);
    keyframesOf(inputs[i], placement.node_offset, poses, nodes);
    index.add(inputs[i].map, poses, nodes, classes);
  }
  report.nodes = static_cast<std::size_t>(graph.numNodes());
  report.edges = static_cast<std::size_t>(graph.numEdges());
  report.loops_disagreeing = edgesBeyond(graph, EdgeKind::Loop, kLoopChi2Bound).size();
  return graph;
}

}  // namespace hazmap::pipeline_detail
