#pragma once
// The map of hazmap live's saves while running, built beside tracking so that a save's cost does
// not grow with the mission (issue 33: an autosave used to re-read the whole spool, ~5 ms a
// frame, three minutes after an hour). The pipeline hands each frame's scan here as tracking saw
// it (a copy into a bounded queue); a thread of its own inserts it into a SegmentedMap
// (map/segmented_map.hpp); a snapshot cuts the segments after its last frame; a save composes the
// map of its snapshot's frames at the snapshot's poses. The final write (the end of the run)
// still rebuilds the map from the spool, exactly as `hazmap run`.
#include <Eigen/Geometry>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>
#include <span>
#include <thread>
#include <vector>

#include "hazmap/map/segmented_map.hpp"
#include "hazmap/pipeline/slam.hpp"

namespace hazmap {

class LiveSaveMap {
 public:
  /// A segment begins every `frames_per_segment` frames and after each cut. `max_queued`: frames
  /// waiting for the thread; one more and the map gives up (compose() then says so and the save
  /// rebuilds from the spool), so tracking never waits for it.
  LiveSaveMap(GlobalMapConfig map, ClassTable table, SegmentedMapConfig segments = {},
              std::size_t frames_per_segment = 100, std::size_t max_queued = 64);
  ~LiveSaveMap();
  LiveSaveMap(const LiveSaveMap&) = delete;
  LiveSaveMap& operator=(const LiveSaveMap&) = delete;

  /// The pipeline's frame hook (its thread): the frame's scan (and its named channels, one value
  /// per point) at its pose now.
  void frame(const SlamFrameEvent& event, std::span<const PointChannel> channels = {});
  /// At a snapshot of `frames` frames (the pipeline's thread, after those frames' hooks).
  void cut(std::size_t frames);
  /// The map of the first `frames` frames at `poses` (a save's thread), once the thread has
  /// inserted them; nullopt when a frame was not taken (a full queue) or no cut was made there.
  std::optional<GlobalMap> compose(std::size_t frames, std::span<const Eigen::Isometry3d> poses);

  std::size_t segments() const { return map_.segments(); }
  bool complete() const;  ///< no frame given up so far

 private:
  struct Item {
    bool is_cut = false;
    std::size_t frame = 0;  // the frame, or the cut's frame count
    LabeledCloud cloud;
    std::vector<PointChannel> channels;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    std::size_t anchor = 0;  // the segment's first frame, and its pose now
    Eigen::Isometry3d anchor_pose = Eigen::Isometry3d::Identity();
  };
  void push(Item item);
  void loop();
  void giveUp();  ///< with m_ held: no more frames; waiting saves are told (compose gives nullopt)

  SegmentedMap map_;
  std::size_t frames_per_segment_, max_queued_;
  // The pipeline's side: where the open segment begins (the thread makes the same segments).
  bool open_ = false;
  std::size_t anchor_ = 0, in_segment_ = 0;
  mutable std::mutex m_;
  std::condition_variable work_, done_;
  std::deque<Item> queue_;
  std::size_t queued_frames_ = 0;
  std::size_t cut_at_ = 0;        // the newest cut the thread has made
  bool given_up_ = false, stopping_ = false;
  std::thread thread_;  // last: started once everything above is constructed
};

}  // namespace hazmap
