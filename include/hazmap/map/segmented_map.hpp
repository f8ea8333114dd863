#pragma once
// SegmentedMap: the GlobalMap of a run in progress, kept so that a loop correction re-places it
// instead of rebuilding it from every scan (hazmap live's saves while running, docs/live.md).
//
// Consecutive frames form segments. A segment is a GlobalMap of its scans, each inserted where it
// was relative to the segment's first frame (its anchor) when it arrived, in the coordinates of
// the anchor's pose when the segment began. The map for later poses is the union of the
// segments, each moved by its anchor's correction (T_anchor_now · T_anchor_then⁻¹,
// GlobalMap::insertMap): its cost follows the segments' cells, not the number of scans. A segment
// is rigid: a later correction that bends the trajectory within it is not followed (the caller
// keeps segments short). Neighbours whose relative placement stayed put between two composes
// merge into one, and beyond `max_segments` the steadiest merge anyway: a long mission keeps few
// segments, so memory and a compose's cost follow the explored area, not the mission's length.
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
  /// Neighbours whose relative placement moved less than this between two composes merge.
  double merge_translation = 0.002;  ///< m
  double merge_rotation = 0.0005;    ///< rad
  std::size_t max_segments = 8;      ///< beyond it the steadiest neighbours merge anyway (>= 2)
};

class SegmentedMap {
 public:
  SegmentedMap(GlobalMapConfig map, ClassTable table, SegmentedMapConfig config = {});
  ~SegmentedMap();

  /// Adds the next frame (`frame` == frames()) at its pose now (T_world_sensor). `anchor` ==
  /// `frame` begins a new segment (the open one closes); otherwise `anchor` is the open segment's
  /// first frame and T_world_anchor_now its pose now: the frame goes in where it lies relative to
  /// it (a correction since the segment began moved both). Throws hazmap::Error for a frame out
  /// of order or another anchor (and as GlobalMap::insert).
  void add(std::size_t frame, const LabeledCloud& scan, std::span<const PointChannel> channels,
           const Eigen::Isometry3d& T_world_sensor, std::size_t anchor, const Eigen::Isometry3d& T_world_anchor_now);
  /// The same, beginning a new segment every `frames_per_segment` frames (all poses as known then).
  void add(std::size_t frame, const LabeledCloud& scan, std::span<const PointChannel> channels,
           std::span<const Eigen::Isometry3d> poses_now, std::size_t frames_per_segment);
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
  std::size_t frames_ = 0;
  mutable std::mutex mutex_;  // guards closed_ (the adder appends, the composer replaces a prefix)
  std::vector<std::shared_ptr<Segment>> closed_;
};

}  // namespace hazmap
