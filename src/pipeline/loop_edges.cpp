#include "pipeline/loop_edges.hpp"

#include "hazmap/graph/optimizer.hpp"
#include "hazmap/loop/consistency.hpp"

namespace hazmap::pipeline_detail {

// Loop closure when tracking is frame to frame (the paper's set-up), measured on naraha
// (docs/pose_graph.md, docs/properties.md):
// - scan-to-scan verification: a submap placed with frame-to-frame increments is blurred by their
//   local drift (seed 1 icp+pgo 0.142 → 0.161 m against submaps);
// - no misfit term in the loop covariance: scan-to-scan loops are already timid (NEES 0.5) and
//   correct a drifting chain (seed 1 property-icp+pgo 0.1135 → 0.1335 m with it);
// - camera-label loops at the matched stretch's own keyframe, not the one nearest the query
//   (the nearest-keyframe loops made the maps worse on all eight seeds).
LoopClosureConfig loopClosureConfigFor(const SlamConfig& config) {
  LoopClosureConfig loop_config = config.loop_closure;
  // Loop verification's ICP is tracking's with its overrides (issue 37: not a copy).
  loop_config.verification.tracking_registration = config.odometry.registration;
  if (config.odometry.mode == OdometryMode::FrameToMap) return loop_config;
  loop_config.submap_keyframes = 0;
  loop_config.verification.misfit_scale = 0.0;
  loop_config.partial_nearest_keyframe = false;
  return loop_config;
}

void setLoopEdges(PoseGraph& graph, const std::vector<LoopClosure>& consistent,
                  const std::vector<std::size_t>& keyframe_frames) {
  std::erase_if(graph.edges, [](const PoseGraphEdge& e) { return e.kind == EdgeKind::Loop; });
  for (const auto& l : consistent)
    graph.addEdge(static_cast<int>(keyframe_frames[l.from]), static_cast<int>(keyframe_frames[l.to]), l.T_from_to,
                  l.information, EdgeKind::Loop);
}

std::vector<LoopClosure> loopsTheSolutionRejects(const PoseGraph& graph, const std::vector<LoopClosure>& loops,
                                                 const std::vector<std::size_t>& keyframe_frames,
                                                 double gate_probability) {
  const double threshold = chiSquareQuantile(6, gate_probability);
  std::vector<LoopClosure> out;
  for (std::size_t i : edgesBeyond(graph, EdgeKind::Loop, threshold)) {
    const PoseGraphEdge& e = graph.edges[i];
    for (const auto& l : loops)
      if (keyframe_frames[l.from] == static_cast<std::size_t>(e.from) && keyframe_frames[l.to] == static_cast<std::size_t>(e.to)) {
        out.push_back(l);
        break;
      }
  }
  return out;
}

}  // namespace hazmap::pipeline_detail
