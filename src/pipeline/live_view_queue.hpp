#pragma once
// The frames waiting for the live view's thread (live_view_feed.cpp): filled by the pipeline's
// thread, emptied in batches by the view's, bounded in memory however far the view falls behind
// (it runs at the lowest priority). A scan is queued while the queued scans stay within the byte
// budget, else skipped for the view (its pose still goes). A correction carries every pose of the
// run so far (a long mission: tens of thousands), and the view only ever needs the newest: a new
// correction supersedes the ones still queued (their frames stay, drawn at their tracked poses
// until the newest correction moves them), so at most one set of corrected poses waits.
#include <Eigen/Geometry>
#include <cstddef>
#include <deque>
#include <memory>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/pipeline/slam.hpp"

namespace hazmap::pipeline_detail {

struct LiveViewItem {
  bool has_frame = true;  ///< false: a correction alone (a save's final poses)
  std::size_t frame = 0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  FrameStatus status = FrameStatus::First;
  std::unique_ptr<LabeledCloud> scan;  ///< null: skipped for the view (its queue was full)
  std::size_t bytes = 0;               ///< the scan's, counted against the budget
  bool correction = false;             ///< earlier poses moved: `corrected` holds them all
  std::vector<Eigen::Isometry3d> corrected;
};

/// Bytes of a scan's arrays.
std::size_t scanBytes(const LabeledCloud& c);

/// Not thread-safe: the caller holds its lock.
class LiveViewQueue {
 public:
  explicit LiveViewQueue(std::size_t scan_bytes) : budget_(scan_bytes) {}

  /// Whether a scan of `bytes` fits now; if so its bytes are reserved (push the item with them).
  bool reserve(std::size_t bytes);
  /// Queues the item; a correction supersedes the queued ones (their poses are released).
  void push(LiveViewItem item);
  /// Everything queued, in order (the scans' bytes stay reserved until release()).
  std::deque<LiveViewItem> take();
  /// The view is done with taken items holding `bytes` of scans.
  void release(std::size_t bytes) { bytes_ -= bytes; }

  bool empty() const { return items_.empty(); }
  std::size_t bytes() const { return bytes_; }
  /// Corrected poses held by queued items (at most one correction's).
  std::size_t queuedPoses() const;
  std::size_t superseded() const { return superseded_; }  ///< corrections replaced before the view took them

 private:
  std::size_t budget_, bytes_ = 0, superseded_ = 0;
  std::deque<LiveViewItem> items_;
};

}  // namespace hazmap::pipeline_detail
