#pragma once
// The live view's map (issue 33): one point per voxel, sent once, and moved with the poses when
// a loop correction moves them. Each point belongs to a *segment* (a run of consecutive frames
// within `segment_length` / `segment_angle_deg` of its first frame, the segment's anchor) and is
// kept in its anchor's coordinates; when corrected poses arrive, the segments whose anchor moved
// are sent as one "anchors" message (32 bytes each), and the page moves their points. A
// correction costs the page bytes per segment moved, not per point: a 20-minute mission walked at
// 1 m/s has ~600 segments of 2 m, ~26 kB of base64 when all of them move.
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <unordered_set>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/map/export.hpp"

namespace hazmap {

struct LiveMapConfig {
  double voxel = 0.2;                  ///< m: one map point per voxel this size
  std::size_t max_points = 1'000'000;  ///< voxels sent at most (the page's memory, a new browser's snapshot)
  std::size_t chunk_points = 20'000;   ///< voxels per message at most
  /// A frame farther than this from its segment's anchor (m, degrees) starts a new segment. Within
  /// a segment the points keep the relative poses they were tracked with (what a correction
  /// changes there is its change over this distance).
  double segment_length = 2.0;
  double segment_angle_deg = 20.0;
  /// A segment is resent when its anchor moved a point `tolerance_range` m away from it by more
  /// than `anchor_tolerance` m since it was last sent.
  double anchor_tolerance = 0.01;
  double tolerance_range = 20.0;
};

/// The map as it grows, for the page: each new voxel once, at its centre, coloured as map.ply
/// colours it (property classes by kind; plain points grey by height, the height range fixed by
/// the first scan), grouped by class. A "map" message: seq (0, 1, …: a page that got a message in
/// its snapshot and again as an update ignores the repeat), segment (its points' segment), pose
/// (the segment's pose the positions were computed at: [x, y, z, qx, qy, qz, qw]), groups [{id,
/// name, kind, css, count}] in the order of the points; xyz = base64 of int16 little-endian voxel
/// indices (x y z per point; position = (index + 0.5) × voxel); rgb = base64 of 3 bytes per point.
/// The page keeps each point in its segment's coordinates (pose⁻¹ × position) and draws it at
/// the segment's newest pose. An "anchors" message: count, segments = base64 of uint32 LE ids,
/// poses = base64 of 7 float32 LE per segment (x y z qx qy qz qw).
///
/// A voxel keeps the class of the first point that reached it; after a correction, "reached"
/// is judged against the moved points. Points beyond int16 voxel indices, or in new voxels once
/// max_points are sent, are counted (dropped()), not sent. Memory: ~60 bytes per point sent (its
/// anchor coordinates and segment, 16; its voxel key in a hash set, ~32; the message kept for new
/// browsers, ~12), at most max_points of them (~60 MB at the default 1,000,000), and one pose per
/// segment.
class LiveMapVoxels {
 public:
  explicit LiveMapVoxels(ClassTable classes, LiveMapConfig config = {}, MapColorConfig colors = {});
  /// Frame `frame`'s scan (sensor frame) at T_world_sensor: messages for the voxels it adds (may be none).
  std::vector<std::string> add(std::size_t frame, const LabeledCloud& scan, const Eigen::Isometry3d& T_world_sensor);
  /// Corrected poses (index = frame; anchors past its end keep theirs): the "anchors" message of
  /// the segments that moved beyond the tolerance (empty: none did).
  std::string reanchor(const std::vector<Eigen::Isometry3d>& poses);
  /// Every segment's pose (a new browser's snapshot); empty without segments.
  std::string anchorsMessage() const;

  std::size_t points() const { return points_.size(); }
  std::size_t dropped() const { return dropped_; }  ///< points not sent (see above)
  std::size_t segments() const { return segments_.size(); }
  /// Every point sent, where the page draws it now (world, voxel centres moved with their segment).
  std::vector<Eigen::Vector3d> drawnPoints() const;

 private:
  struct Segment {
    std::size_t frame = 0;                                   ///< the anchor
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  ///< the anchor's newest pose (what the page has)
  };
  struct Point {
    Eigen::Vector3f local;  ///< the voxel centre in its segment's anchor coordinates
    std::uint32_t segment;
  };
  std::uint32_t segmentFor(std::size_t frame, const Eigen::Isometry3d& pose);
  void rekey();

  ClassTable classes_;
  LiveMapConfig config_;
  MapColorConfig colors_;
  std::vector<Segment> segments_;
  std::optional<std::uint32_t> open_;  ///< the segment new frames join while near its anchor
  std::vector<Point> points_;
  std::unordered_set<std::uint64_t> keys_;  ///< the voxels of points_ at their segments' poses
  std::optional<std::pair<double, double>> height_range_;
  std::size_t dropped_ = 0;
  std::size_t messages_ = 0;
};

/// The anchors message for these segments and poses (tests decode it as the page does).
std::string liveAnchorsMessage(const std::vector<std::uint32_t>& segments, const std::vector<Eigen::Isometry3d>& poses);

}  // namespace hazmap
