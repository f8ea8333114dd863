#pragma once
// SegmentedMap: the GlobalMap of a run in progress, kept so that a loop correction re-places it
// instead of rebuilding it from every scan (hazmap live's saves while running, docs/live.md).
//
// Consecutive frames form segments. A segment is a GlobalMap of its scans inserted at their poses
// as known when they arrived, and it remembers its first frame's (its anchor's) pose then. The map
// for later poses is the union of the segments, each moved by its anchor's correction
// (T_anchor_now · T_anchor_then⁻¹, GlobalMap::insertMap): its cost follows the segments' cells,
// not the number of scans. A segment is rigid, so it never spans a correction of earlier poses (a
// new `epoch` closes the open one) nor more than `max_frames`; neighbours whose relative placement
// has stayed put between two composes merge into one, so a long mission keeps few segments.
//
// One thread adds frames (add, close); another composes (compose): both may run at once.
#include <Eigen/Geometry>
#include <cstddef>
#include <memory>
#include <mutex>
#include <span>
#include <vector>

#include "hazmap/map/global_map.hpp"

namespace hazmap {

struct SegmentedMapConfig {
  std::size_t max_frames = 100;      ///< a segment closes after this many frames (>= 1)
  /// Neighbours whose relative placement moved less than this between two composes merge.
  double merge_translation = 0.002;  ///< m
  double merge_rotation = 0.0005;    ///< rad
  std::size_t max_segments = 128;    ///< beyond it the steadiest neighbours merge anyway (>= 2)
};

class SegmentedMap {
 public:
  SegmentedMap(GlobalMapConfig map, ClassTable table, SegmentedMapConfig config = {});
  ~SegmentedMap();

  /// Adds the next frame (`frame` == frames()) at its pose now (T_world_sensor). `epoch` counts
  /// corrections of earlier poses (SlamFrameEvent::corrections): a new one closes the open
  /// segment. Throws hazmap::Error for a frame out of order (and as GlobalMap::insert).
  void add(std::size_t frame, const LabeledCloud& scan, std::span<const PointChannel> channels,
           const Eigen::Isometry3d& T_world_sensor, std::size_t epoch);
  /// Closes the open segment: the frames so far can be composed (a snapshot's cut).
  void close();

  std::size_t frames() const;    ///< frames added (adding thread)
  std::size_t segments() const;  ///< closed segments

  /// The map of the first `frames` frames, each segment moved by its anchor's correction in
  /// `poses` (T_world_sensor of at least those frames). Needs a cut there (close() right after
  /// frame `frames` − 1): throws hazmap::Error otherwise. Merges steady neighbours first.
  GlobalMap compose(std::size_t frames, std::span<const Eigen::Isometry3d> poses);

 private:
  struct Segment;
  std::shared_ptr<Segment> merged(const std::vector<std::shared_ptr<Segment>>& run,
                                  std::span<const Eigen::Isometry3d> corrections) const;
  void mergeSteadyNeighbours(std::vector<std::shared_ptr<Segment>>& prefix,
                             std::span<const Eigen::Isometry3d> poses) const;

  GlobalMapConfig map_config_;
  ClassTable table_;
  SegmentedMapConfig config_;
  std::unique_ptr<Segment> open_;  // the adding thread's
  std::size_t frames_ = 0, epoch_ = 0;
  mutable std::mutex mutex_;  // guards closed_ (the adder appends, the composer replaces a prefix)
  std::vector<std::shared_ptr<Segment>> closed_;
};

}  // namespace hazmap
