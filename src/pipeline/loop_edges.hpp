#pragma once
// Verified loops as pose-graph edges, and the loop stage's settings per tracking mode: the pairwise-consistent set replaces the graph's loop edges
// before every optimisation, and a loop the solution cannot agree with is found afterwards.
#include <cstddef>
#include <vector>

#include "hazmap/graph/pose_graph.hpp"
#include "hazmap/loop/loop_closure.hpp"
#include "hazmap/pipeline/slam.hpp"

namespace hazmap::pipeline_detail {

/// The loop stage's settings for the run's tracking mode (frame to frame: the paper's set-up).
LoopClosureConfig loopClosureConfigFor(const SlamConfig& config);
/// Replaces the graph's loop edges by `consistent` (keyframe indices → frames by keyframe_frames).
void setLoopEdges(PoseGraph& graph, const std::vector<LoopClosure>& consistent,
                  const std::vector<std::size_t>& keyframe_frames);
/// The loops among `loops` whose whitened residual in the graph's solution exceeds the χ²(6)
/// quantile of gate_probability.
std::vector<LoopClosure> loopsTheSolutionRejects(const PoseGraph& graph, const std::vector<LoopClosure>& loops,
                                                 const std::vector<std::size_t>& keyframe_frames,
                                                 double gate_probability);

}  // namespace hazmap::pipeline_detail
