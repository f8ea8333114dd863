#pragma once
// The live view's messages (issue 33, part 4): what `hazmap live` publishes to the page's
// WebSocket and answers on GET /status, as JSON text. Plain functions of plain data, so the
// tests judge them without a server or a browser (docs/live.md lists the fields).
//
//   {"type":"pose", "frame", "p":[x,y,z], "yaw", "status"}     the newest pose (a coalesced state)
//   {"type":"track", "frame", "p":[x,y,z]}                      one trajectory point, in order
//   {"type":"trajectory", "points":[[x,y,z],…]}                 the whole (corrected) trajectory
//   {"type":"map", "seq", "voxel", "segment", "pose", "groups":[…], "xyz", "rgb"}  new map voxels
//   {"type":"anchors", "count", "segments", "poses"}            map segments moved (live_map_voxels.hpp)
//   {"type":"hazards", "origin":"live"|"saved", "hazards":[…]}  the hazard list (viewer format)
//   {"type":"status", "status":{…}}                             the status line (= GET /status)
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/map/export.hpp"
#include "hazmap/map/hazards.hpp"
#include "hazmap/properties/live_camera.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/pipeline/frame_latency.hpp"

namespace hazmap {

/// GET /status and the page's status line. The contract's fields are frames, packets, drops,
/// state, last_packet_age_s (null before the first datagram) and hazards; the rest is extra.
struct LiveStatus {
  std::size_t frames = 0;      ///< frames tracked
  std::uint64_t packets = 0;   ///< datagrams received
  std::uint64_t drops = 0;     ///< datagrams lost (kernel, queue, truncated)
  std::string state;           ///< waiting for sensor | starting | tracking | saving | stopped by …
  std::optional<double> last_packet_age_s;
  std::size_t hazards = 0;
  double frames_per_s = 0;
  std::size_t queue_datagrams = 0, queue_bytes = 0;
  std::string tracking;        ///< the newest frame's tracking status (tracked, fallback, …)
  std::size_t map_points = 0;  ///< voxels the page has been sent
  std::size_t map_corrections = 0;  ///< loop corrections (or saves) that moved map segments
  std::size_t back_end_backlog = 0;  ///< frames tracked, not yet in the back end's graph
  std::size_t view_frames_skipped = 0;  ///< scans the view's thread had no room for (poses still sent)
  std::size_t clients = 0, clients_dropped = 0;
  std::size_t saves = 0;
  std::string last_save;       ///< the folder of the last save, or its error
  /// The last complete save: its frames, how long it took to write, and the age of the state it
  /// holds (since its snapshot was taken: what a kill -9 now would lose). Null before the first.
  std::size_t last_save_frames = 0;
  std::optional<double> last_save_seconds, last_save_age_s;
  std::vector<LiveCameraStats> cameras;  ///< the live property cameras (empty without --camera)
  /// Frames rejected, pipeline errors, frames dropped unused, stalls and scans without a frame,
  /// summed over the cameras.
  std::uint64_t camera_warnings = 0;
  /// A scan's newest point to its pose over the most recent frames (null before the first).
  std::optional<RecentLatency::Summary> latency_ms;
};
std::string liveStatusJson(const LiveStatus& status);
/// The cameras' counts as /status has them (a JSON array), for run.json too.
std::string liveCamerasJson(const std::vector<LiveCameraStats>& cameras);
std::string liveStatusMessage(const LiveStatus& status);

std::string livePoseMessage(std::size_t frame, const Eigen::Isometry3d& pose, FrameStatus status);
std::string liveTrackMessage(std::size_t frame, const Eigen::Vector3d& position);
std::string liveTrajectoryMessage(const std::vector<Eigen::Vector3d>& positions);
/// `origin`: "live" (the view's own map so far) or "saved" (the run folder's hazards.json).
std::string liveHazardsMessage(const std::vector<Hazard>& hazards, const ClassTable& classes,
                               const std::string& origin, const MapColorConfig& colors = {});

}  // namespace hazmap
