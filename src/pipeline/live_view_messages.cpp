#include "hazmap/pipeline/live_view_messages.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <map>

#include "hazmap/map/viewer.hpp"
#include "map/viewer_data.hpp"

namespace hazmap {

NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(LiveCameraStats, name, frames, rejected, ring_dropped, scans_without_image, stalls,
                                   stalled, pipeline_errors, restarts, last_error);

namespace {

using nlohmann::json;

double mm(double v) { return std::round(v * 1000.0) / 1000.0; }
json xyz(const Eigen::Vector3d& p) { return json::array({mm(p.x()), mm(p.y()), mm(p.z())}); }

json cameraObject(const LiveCameraStats& c) {
  json j = c;  // every count (to_json below)
  j["last_frame_age_s"] = c.last_frame_age_s ? json(std::round(*c.last_frame_age_s * 1000) / 1000) : json();
  return j;
}

json latencyObject(const std::optional<RecentLatency::Summary>& l) {
  if (!l) return nullptr;
  const auto ms = [](double v) { return std::round(v * 10) / 10; };
  return {{"p50", ms(l->p50)}, {"p99", ms(l->p99)}, {"max", ms(l->max)}, {"frames", l->frames}};
}

json statusObject(const LiveStatus& s) {
  json cameras = json::array();
  for (const auto& c : s.cameras) cameras.push_back(cameraObject(c));
  return {{"frames", s.frames},
          {"packets", s.packets},
          {"drops", s.drops},
          {"state", s.state},
          {"last_packet_age_s", s.last_packet_age_s ? json(std::round(*s.last_packet_age_s * 1000) / 1000) : json()},
          {"hazards", s.hazards},
          {"frames_per_s", std::round(s.frames_per_s * 100) / 100},
          {"queue_datagrams", s.queue_datagrams},
          {"queue_bytes", s.queue_bytes},
          {"tracking", s.tracking},
          {"map_points", s.map_points},
          {"map_corrections", s.map_corrections},
          {"back_end_backlog", s.back_end_backlog},
          {"view_frames_skipped", s.view_frames_skipped},
          {"clients", s.clients},
          {"clients_dropped", s.clients_dropped},
          {"saves", s.saves},
          {"last_save", s.last_save},
          {"last_save_frames", s.last_save_frames},
          {"last_save_seconds", s.last_save_seconds ? json(std::round(*s.last_save_seconds * 1000) / 1000) : json()},
          {"last_save_age_s", s.last_save_age_s ? json(std::round(*s.last_save_age_s * 1000) / 1000) : json()},
          {"cameras", cameras},
          {"camera_warnings", s.camera_warnings},
          {"latency_ms", latencyObject(s.latency_ms)}};
}

}  // namespace

std::string liveStatusJson(const LiveStatus& status) { return statusObject(status).dump(); }

std::string liveCamerasJson(const std::vector<LiveCameraStats>& cameras) {
  json out = json::array();
  for (const auto& c : cameras) out.push_back(cameraObject(c));
  return out.dump();
}

std::string liveStatusMessage(const LiveStatus& status) {
  return json{{"type", "status"}, {"status", statusObject(status)}}.dump();
}

std::string livePoseMessage(std::size_t frame, const Eigen::Isometry3d& pose, FrameStatus status) {
  const Eigen::Vector3d x = pose.linear().col(0);
  return json{{"type", "pose"}, {"frame", frame}, {"p", xyz(pose.translation())},
              {"yaw", std::round(std::atan2(x.y(), x.x()) * 1e4) / 1e4}, {"status", toString(status)}}
      .dump();
}

std::string liveTrackMessage(std::size_t frame, const Eigen::Vector3d& position) {
  return json{{"type", "track"}, {"frame", frame}, {"p", xyz(position)}}.dump();
}

std::string liveTrajectoryMessage(const std::vector<Eigen::Vector3d>& positions) {
  json points = json::array();
  for (const auto& p : positions) points.push_back(xyz(p));
  return json{{"type", "trajectory"}, {"points", points}}.dump();
}

std::string liveHazardsMessage(const std::vector<Hazard>& hazards, const ClassTable& classes,
                               const std::string& origin, const MapColorConfig& colors) {
  return json{{"type", "hazards"}, {"origin", origin},
              {"hazards", json::parse(viewerHazardsJson(hazards, classes, colors))}}
      .dump();
}

}  // namespace hazmap
