#pragma once
// The back end of one run (paper Fig. 1, right): keyframes, property-landmark (or distance) loop
// closure verified by ICP, map anchors, and pose-graph optimisation with information = inverse
// ICP covariance (eq. 3). It works on the run's graph and records (SlamResult) while the front
// end (slam.cpp) tracks and adds each frame's node and odometry edge.
#include <cstddef>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/journaled_list.hpp"
#include "hazmap/io/gravity.hpp"
#include "hazmap/loop/loop_closure.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "hazmap/sources/scan_source.hpp"
#include "hazmap/io/keyframe_spill.hpp"
#include "pipeline/edge_journal.hpp"
#include "pipeline/frame_record_store.hpp"
#include "pipeline/loop_schedule.hpp"
#include "pipeline/map_anchors.hpp"
#include "pipeline/tracked_poses.hpp"

namespace hazmap::pipeline_detail {

class BackEnd {
 public:
  /// `tracked` = the tracked poses (T_world_sensor per frame), read when keyframes are anchored;
  /// `records` = the run's frame records (result.frames, or the newest of them and a journal).
  BackEnd(const SlamConfig& config, SlamResult& result, const FrameRecordStore& records,
          const TrackedPoses& tracked);

  /// The loop detector over the run's classes; old keyframes are re-read from `source` when a
  /// loop needs them (or from copies on disk when the source cannot re-read), holding
  /// `source_lock` (when given) while one is re-read.
  void start(const ClassTable& classes, ScanSource& source, std::mutex* source_lock = nullptr);
  /// The newest frame's odometry edge covariance (what the loop gate chains) and its share no
  /// registration vouched for (what the anchors chain). replaceStep: a re-estimated frame's.
  void addStep(const FrameRecord& rec, const Matrix6d& edge_covariance);
  void replaceStep(std::size_t frame, const Matrix6d& edge_covariance) { step_covariance_[frame] = edge_covariance; }
  /// From now on the gate's step covariances and the graph's edges older than the newest `keep`
  /// frames go to journals (the back end on its own thread: a long mission).
  void journalOlderThan(std::size_t keep);
  /// Every edge of the graph (those in the journal first), the graph left as it is.
  std::vector<PoseGraphEdge> allEdges() const { return edges_.allEdges(result_.graph); }
  /// The newest frame's gravity-direction prior when its scan has an IMU measurement.
  void addGravityPrior(const std::optional<GravitySample>& gravity);
  /// The newest frame becomes a keyframe: its anchor edge, loop candidates verified by ICP, and
  /// an online optimisation as soon as one is accepted (on a large graph, every few keyframes:
  /// solveDue).
  void closeLoops(LabeledCloud cloud);
  /// The last optimisation with the consistent loops; the loops and rejections recorded.
  void finish();
  /// A snapshot's loop records (`finish` makes the run's): the keyframes so far and the loops
  /// in the graph now, those of the newest consistent set (`snapshot` holds the graph's edges).
  void describeLoopsSoFar(SlamResult& snapshot) const;

 private:
  Matrix6d relativeCovariance(std::size_t from, std::size_t to) const;
  void optimiseWithLoops();
  void solveWithConsistentLoops();
  void journalOldEdges();
  std::string optimise();
  /// Beyond SlamConfig::online_keyframe_graph_after frames, until the end: the keyframes' graph.
  bool solvesKeyframes() const;
  PoseGraphReport optimiseKeyframes(std::string& failure);
  void reject(const LoopClosure& l, LoopRejection why, std::string detail);
  void dropLoop(const LoopClosure& l, LoopRejection why, const std::string& detail);
  void recordDetection(const LoopDetection& detection);
  void recordLoops(const std::vector<LoopClosure>& consistent);
  LoopRecord recordOf(const LoopClosure& l) const;  ///< run.json's entry of an accepted loop
  bool gravityAloneHelps() const;
  /// Whether loops accepted by now are solved at this keyframe (keyframesBetweenSolves).
  bool solveDue(std::size_t keyframe) const;
  PoseList keyframeEstimate() const;

  const SlamConfig& config_;
  SlamResult& result_;
  const FrameRecordStore& records_;
  const TrackedPoses& tracked_;
  std::unique_ptr<LoopDetector> loops_;
  LoopSchedule schedule_;
  std::optional<KeyframeSpill> spill_;
  std::vector<std::size_t> keyframe_frames_;  // keyframe index → frame index
  JournaledList<Matrix6d> step_covariance_{"step covariance journal"};  // frame → its odometry edge's covariance
  MapAnchors anchors_;
  EdgeJournal edges_;
  std::size_t journal_keep_ = 0;  // 0: the graph's edges all in memory
  bool loops_pending_ = false;           // loops accepted since the last solve
  std::size_t last_solve_keyframe_ = 0;  // the keyframe of the last solve with loops
  bool finishing_ = false;               // the end's solves: of the whole graph
};

}  // namespace hazmap::pipeline_detail
