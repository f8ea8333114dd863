#pragma once
// A long mission's pose graph solved on its keyframes (issue 33): the graph has a node per frame
// (the paper's), so an online solve's time and memory grow with every frame — at 36,000 frames a
// solve took 2–3 s and ~290 MB of Ceres/CHOLMOD working memory (docs/live.md). Between two
// keyframes the only edges are the odometry chain, so the keyframes' graph carries the same
// information about them: each chain folded into one edge (its increments composed, their
// covariances chained, first order), loop and anchor edges and gravity priors as they are. The
// frames between move with the keyframe before them (rigidly); the end's solve of the whole graph
// places them exactly.
#include <optional>
#include <vector>

#include "hazmap/graph/pose_graph.hpp"

namespace hazmap {

/// The graph of `kept` nodes (ascending node indices; the first must be the graph's fixed node):
/// node j of the result is graph node kept[j]. The odometry edges between two consecutive kept
/// nodes fold into one; every other edge and every gravity prior must join kept nodes. nullopt
/// when the graph is not such a chain (an odometry edge that skips a node, a missing or doubled
/// link, another edge or a prior on a dropped node): then only the whole graph can be solved.
std::optional<PoseGraph> keyframeGraph(const PoseGraph& graph, const std::vector<int>& kept);

/// Writes a keyframe graph's solution back: each kept node takes its solved pose, each dropped node
/// moves with the kept node before it (T_new = T_kept,new · T_kept,old⁻¹ · T_old), and the
/// estimated gravity direction is copied.
void applyKeyframeSolution(PoseGraph& graph, const std::vector<int>& kept, const PoseGraph& solved);

}  // namespace hazmap
