#include "pipeline/graph_side.hpp"

#include <string>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "pipeline/edge_noise.hpp"

namespace hazmap::pipeline_detail {

GraphSide::GraphSide(const SlamConfig& config, SlamResult& result, const TrackedPoses& tracked,
                     const Eigen::Isometry3d& start)
    : config_(config), result_(result), records_(result.frames), tracked_(tracked), start_(start) {}

void GraphSide::start(const ClassTable& classes, ScanSource& source, std::mutex* source_lock) {
  if (!usesPoseGraph(config_.method)) return;
  back_end_.emplace(config_, result_, records_, tracked_);
  back_end_->start(classes, source, source_lock);
}

// Every method records its graph (graph.g2o); the node continues from the previous node, which
// an online optimisation may already have moved.
void GraphSide::addFrame(const FrameRecord& rec) {
  PoseGraph& graph = result_.graph;
  graph.addNode(graph.poses.empty() ? start_ : normalized(graph.poses.back() * rec.T_prev_curr));
  if (rec.index == 0) {
    if (back_end_) back_end_->addStep(rec, Matrix6d::Zero());
    return;
  }
  // Information = inverse of the calibrated ICP covariance (eq. 3), or the wheel noise when the
  // tracker fell back to the encoders; the covariance is kept for the loop gate.
  const EdgeNoise noise = odometryEdgeNoise(rec, config_);
  if (back_end_) back_end_->addStep(rec, noise.covariance);
  graph.addEdge(static_cast<int>(rec.index - 1), static_cast<int>(rec.index), rec.T_prev_curr, noise.information,
                EdgeKind::Odometry);
}

void GraphSide::replaceFrames(const std::vector<std::size_t>& changed) {
  if (changed.empty()) return;
  for (std::size_t k : changed) {
    const FrameRecord& rec = records_.at(k);
    const EdgeNoise noise = odometryEdgeNoise(rec, config_);
    if (back_end_) back_end_->replaceStep(k, noise.covariance);
    bool replaced = false;
    for (PoseGraphEdge& e : result_.graph.edges)
      if (e.kind == EdgeKind::Odometry && e.from == static_cast<int>(k - 1) && e.to == static_cast<int>(k)) {
        e.T_from_to = rec.T_prev_curr;
        e.information = noise.information;
        replaced = true;
      }
    // Kept in memory by the journals' margin (BackEndThread); never a silent miss.
    if (!replaced) fail("pose graph", "frame " + std::to_string(k) + "'s odometry edge is not in memory to be re-estimated");
  }
  chainFrom(result_.graph.poses, records_, changed.front());
}

void GraphSide::journalOlderThan(std::size_t keep) {
  records_.journalOlderThan(keep);
  if (back_end_) back_end_->journalOlderThan(keep);
}

std::vector<PoseGraphEdge> GraphSide::allEdges() const {
  return back_end_ ? back_end_->allEdges() : result_.graph.edges;
}

void GraphSide::addGravityPrior(const std::optional<GravitySample>& gravity) {
  if (back_end_) back_end_->addGravityPrior(gravity);
}

void GraphSide::closeLoops(LabeledCloud cloud) {
  if (back_end_) back_end_->closeLoops(std::move(cloud));
}

void GraphSide::finish() {
  if (back_end_) back_end_->finish();
}

}  // namespace hazmap::pipeline_detail
