#pragma once
// The asynchronous back end (issue 33 part 3, SlamConfig::back_end own-thread): the graph's side of a
// run (graph_side.hpp: nodes, odometry edges, loop search, verification, optimisation) on a
// thread of its own, so tracking never waits for a loop stage. What crosses between the two
// threads is explicit and small: each tracked frame by value (its record, its tracked pose, a
// keyframe's scan moved in), one way; the newest optimised poses as an immutable shared vector,
// the other way, which the tracker applies at a frame boundary. The back end applies the frames in
// the order they were tracked, and the tracker reads nothing the back end computes, so the graph
// it builds, hence the final answer, is the one the synchronous schedule builds.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "hazmap/pipeline/slam.hpp"
#include "pipeline/graph_side.hpp"

namespace hazmap::pipeline_detail {

/// One tracked frame, as the back end needs it.
struct TrackedFrame {
  FrameRecord record;
  Eigen::Isometry3d tracked_pose = Eigen::Isometry3d::Identity();
  /// Earlier frames the tracker re-estimated with this one (issue 19): their new records.
  std::vector<FrameRecord> reestimated;
  bool keyframe = false;
  std::optional<GravitySample> gravity;  ///< a keyframe's, when its scan had one
  LabeledCloud cloud;                    ///< a keyframe's scan as tracking saw it (empty otherwise)
  std::chrono::steady_clock::time_point queued_at{};  ///< set by BackEndThread::push
};

class BackEndThread {
 public:
  /// Starts the thread. `before_loop_stage` (tests; may be empty) is called on the back end's
  /// thread with a keyframe's frame index before its loop stage.
  BackEndThread(const SlamConfig& config, const Eigen::Isometry3d& start, const ClassTable& classes,
                ScanSource& source, std::mutex& source_lock, std::function<void(std::size_t)> before_loop_stage);
  ~BackEndThread();
  BackEndThread(const BackEndThread&) = delete;
  BackEndThread& operator=(const BackEndThread&) = delete;

  /// Tracking has a scan in hand (trackingBegins) or waits for the next one (trackingWaits): the back
  /// end works only while tracking has waited a moment for input, pausing at its yield points
  /// (core/yield_point.hpp) otherwise, unless the frame it works on was queued long ago
  /// (back_end_thread.cpp: kInputGrace, kMaxYieldLag). Tracking's thread only.
  void trackingBegins();
  void trackingWaits();
  /// Queues a frame; waits only while the queued keyframe scans exceed slam.back_end_queue_mb
  /// (the back end's turn meanwhile). Rethrows what failed on the back end's thread.
  void push(TrackedFrame frame);
  /// The newest optimised poses (nodes 0..m) not taken yet; null when none came since.
  std::shared_ptr<const std::vector<Eigen::Isometry3d>> takeSolution();
  /// Frames queued or being applied (not yet in the graph).
  std::size_t backlog();
  /// Once every frame queued so far is in the graph, `deliver` gets a copy of the back end's
  /// result, on the back end's thread; tracking goes on meanwhile. finish() waits for it.
  void snapshotOfQueued(std::function<void(SlamResult)> deliver);
  /// Every queued frame, then the final optimisation (BackEnd::finish); the back end's result.
  SlamResult finish();

 private:
  void run();
  void apply(TrackedFrame& frame);
  void giveWayToTracking();
  bool backEndsTurn(std::chrono::steady_clock::time_point now) const;
  std::chrono::steady_clock::time_point waitingSince() const;
  /// Tracking waits for input since `waiting_since` (the epoch: the back end's turn at once).
  void releaseTurn(std::chrono::steady_clock::time_point waiting_since);
  void waitIdle(std::unique_lock<std::mutex>& lock);
  bool snapshotDue() const;
  void deliverSnapshot(std::unique_lock<std::mutex>& lock);
  SlamResult copyOfResult();
  void rethrow();

  const SlamConfig& config_;
  SlamResult result_;                        // back end's thread only, except while idle
  TrackedPoses tracked_{"tracked pose journal"};  // back end's thread only
  GraphSide graph_;
  std::function<void(std::size_t)> before_loop_stage_;
  std::size_t optimisations_published_ = 0;
  std::size_t frames_applied_ = 0;  // back end's thread only

  std::mutex m_;  // everything below
  std::condition_variable wake_, idle_, room_;
  std::deque<TrackedFrame> queue_;
  std::size_t frames_queued_ = 0;  // ever
  struct SnapshotRequest {
    std::size_t frames = 0;  // delivered once this many frames are in the graph
    std::function<void(SlamResult)> deliver;
  };
  std::deque<SnapshotRequest> snapshots_;
  std::size_t queued_bytes_ = 0;
  bool busy_ = false, delivering_ = false, stop_ = false;
  std::exception_ptr failure_;
  std::shared_ptr<const std::vector<Eigen::Isometry3d>> solution_;

  std::atomic<bool> tracking_{false};  // tracking has a scan in hand
  std::atomic<std::chrono::steady_clock::rep> waiting_since_{0};  // … else waits for one since then
  std::mutex turn_m_;  // the back end's wait for its turn
  std::condition_variable turn_over_;
  std::chrono::steady_clock::time_point applying_queued_at_{};  // back end's thread only
  bool sharing_cores_ = false;  // back end's thread only: out of SCHED_IDLE while far behind
  void keepUp(std::chrono::steady_clock::time_point now);

  std::thread thread_;  // last: started once the members above exist
};

}  // namespace hazmap::pipeline_detail
