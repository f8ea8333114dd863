#pragma once
// Several pose graphs as one (issue 34, merging maps): a later graph's nodes and edges appended
// to an earlier one, its poses moved into the earlier one's frame. The edges keep their
// information (each map's own covariances), so in a joint solve a map moves only as much as the
// evidence joining it to the others says.
#include <Eigen/Geometry>

#include "hazmap/graph/pose_graph.hpp"

namespace hazmap {

/// Appends `graph`'s nodes (T_into_graph · pose, ids continuing after `into`'s largest) and edges
/// (indices shifted, information and kind kept) to `into`; returns the index of its first node.
/// Gravity priors come along. Throws hazmap::Error when the
/// dimensions differ.
int appendGraph(PoseGraph& into, const PoseGraph& graph, const Eigen::Isometry3d& T_into_graph);

}  // namespace hazmap
