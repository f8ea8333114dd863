#pragma once
// The pose graph's side of a run, fed one tracked frame at a time (paper Fig. 1, right): each
// frame's node chained from the previous (possibly optimised) node, its odometry edge
// (information = inverse ICP covariance, eq. 3), re-estimated lost frames, and on keyframes the
// gravity prior and the back end's loop stage. The same code serves both schedules
// (SlamConfig::back_end): on the tracker's thread (offline, `hazmap run`), or on the
// back end's own thread with copies of the records (back_end_thread.hpp), so both build the same
// graph from the same sequence of calls.
#include <algorithm>
#include <mutex>
#include <optional>
#include <vector>

#include "hazmap/core/se3.hpp"
#include "hazmap/io/gravity.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "pipeline/back_end.hpp"
#include "pipeline/frame_record_store.hpp"
#include "pipeline/tracked_poses.hpp"

namespace hazmap::pipeline_detail {

class GraphSide {
 public:
  /// `result`: the graph, the records (frames) and the loop records; `tracked`: the tracked pose
  /// of each frame (read by the map anchors). Both are the caller's, appended by the caller.
  GraphSide(const SlamConfig& config, SlamResult& result, const TrackedPoses& tracked,
            const Eigen::Isometry3d& start);

  /// PGO methods: the back end over the run's classes. `source_lock` (may be null) is held while
  /// an old keyframe is re-read from `source` (the tracker reads it on another thread).
  void start(const ClassTable& classes, ScanSource& source, std::mutex* source_lock);
  bool hasBackEnd() const { return back_end_.has_value(); }

  /// The newest record's node and odometry edge (result.frames.back() is `rec`'s place).
  void addFrame(const FrameRecord& rec);
  /// Frames whose records (result.frames) the tracker re-estimated (ascending): their edges and
  /// the gate's covariances; the nodes from the first on chained again.
  void replaceFrames(const std::vector<std::size_t>& changed);
  /// The newest frame is a keyframe: its gravity prior (when the scan had one).
  void addGravityPrior(const std::optional<GravitySample>& gravity);
  /// The newest keyframe's loop stage: anchor edge, loop search and verification, optimisation.
  void closeLoops(LabeledCloud cloud);
  void finish();
  /// A snapshot's keyframe count and loops so far (BackEnd::describeLoopsSoFar); none without PGO.
  void describeLoopsSoFar(SlamResult& snapshot) const {
    if (back_end_) back_end_->describeLoopsSoFar(snapshot);
  }
  /// The records the graph's side reads: a view of result.frames unless journalled.
  FrameRecordStore& records() { return records_; }
  /// From now on the records, the loop gate's step covariances and the graph's edges older than the
  /// newest `keep` frames go to journals (the back end on its own thread: a long mission's memory
  /// stays bounded).
  void journalOlderThan(std::size_t keep);
  /// Every edge of the run's graph (some may be in the journal), the graph left as it is.
  std::vector<PoseGraphEdge> allEdges() const;

 private:
  const SlamConfig& config_;
  SlamResult& result_;
  FrameRecordStore records_;
  const TrackedPoses& tracked_;
  Eigen::Isometry3d start_;
  std::optional<BackEnd> back_end_;
};

/// poses[k] = poses[k - 1] · increment(k) for k from `first` on, below `frames` (the chain of
/// increments). `poses`: a list of poses (std::vector, or a JournaledList whose entries from
/// first − 1 on are in memory).
template <class Poses, class IncrementOf>
void chainFrom(Poses& poses, std::size_t first, std::size_t frames, IncrementOf increment) {
  for (std::size_t k = std::max<std::size_t>(first, 1); k < poses.size() && k < frames; ++k)
    poses[k] = normalized(poses[k - 1] * increment(k));
}
/// The same with the records' T_prev_curr (records from `first` on must be in the store's list).
template <class Poses>
void chainFrom(Poses& poses, const FrameRecordStore& records, std::size_t first) {
  chainFrom(poses, first, records.size(), [&](std::size_t k) -> const Eigen::Isometry3d& { return records.at(k).T_prev_curr; });
}

}  // namespace hazmap::pipeline_detail
