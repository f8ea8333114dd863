#include "hazmap/pipeline/live_view_messages.hpp"

#include <fmt/format.h>
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
          {"view_frames_skipped", s.view_frames_skipped},
          {"clients", s.clients},
          {"clients_dropped", s.clients_dropped},
          {"saves", s.saves},
          {"last_save", s.last_save},
          {"cameras", cameras},
          {"camera_warnings", s.camera_warnings}};
}

template <typename T>
void appendLittleEndian(std::vector<std::uint8_t>& out, T value) {
  for (std::size_t k = 0; k < sizeof(T); ++k) out.push_back(std::uint8_t((std::uint64_t(value) >> (8 * k)) & 0xff));
}

// 21 bits per axis, offset to unsigned: one 64-bit key per voxel.
std::uint64_t voxelKey(const Eigen::Vector3i& v) {
  const auto u = [](int c) { return std::uint64_t(std::uint32_t(c + (1 << 20)) & 0x1fffff); };
  return u(v.x()) | u(v.y()) << 21 | u(v.z()) << 42;
}

struct NewVoxel {
  Eigen::Vector3i index;
  ClassId label;
  Rgb color;
};

std::string cssColor(const Rgb& c) { return fmt::format("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]); }

/// One "map" message of voxels already grouped by class.
std::string mapMessage(std::size_t seq, const std::vector<NewVoxel>& voxels, double voxel, const ClassTable& classes,
                       const MapColorConfig& colors) {
  json groups = json::array();
  std::vector<std::uint8_t> positions, rgb;
  positions.reserve(voxels.size() * 6);
  rgb.reserve(voxels.size() * 3);
  for (std::size_t i = 0; i < voxels.size(); ++i) {
    const NewVoxel& v = voxels[i];
    if (groups.empty() || groups.back()["id"] != v.label) {
      const ClassInfo* info = classes.find(v.label);
      const std::string kind = info ? toString(info->kind) : "none";
      const Rgb swatch = info ? propertyColor(*info, colors) : Rgb{160, 160, 160};
      groups.push_back({{"id", v.label}, {"name", info ? info->name : "class " + std::to_string(v.label)},
                        {"kind", kind}, {"css", cssColor(swatch)}, {"count", 0}});
    }
    groups.back()["count"] = groups.back()["count"].get<std::size_t>() + 1;
    for (int k = 0; k < 3; ++k) {
      appendLittleEndian(positions, std::uint16_t(std::int16_t(v.index[k])));
      rgb.push_back(v.color[k]);
    }
  }
  return json{{"type", "map"},
              {"seq", seq},
              {"voxel", voxel},
              {"groups", groups},
              {"xyz", viewer::base64(positions.data(), positions.size())},
              {"rgb", viewer::base64(rgb.data(), rgb.size())}}
      .dump();
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

LiveMapVoxels::LiveMapVoxels(ClassTable classes, LiveMapConfig config, MapColorConfig colors)
    : classes_(std::move(classes)), config_(config), colors_(colors) {}

std::vector<std::string> LiveMapVoxels::add(const LabeledCloud& scan, const Eigen::Isometry3d& T_world_sensor) {
  LabeledCloud world;
  world.points.reserve(scan.size());
  world.classes.reserve(scan.size());
  const Eigen::Isometry3f T = T_world_sensor.cast<float>();
  for (std::size_t i = 0; i < scan.size(); ++i)
    if (scan.points[i].allFinite()) {
      world.points.push_back(T * scan.points[i]);
      world.classes.push_back(scan.classes.empty() ? ClassId{0} : scan.classes[i]);
    }
  if (!height_range_ && !world.empty()) height_range_ = heightRange(world, classes_, colors_);
  std::vector<NewVoxel> fresh;
  constexpr int kLimit = 32767;  // int16 in the message
  for (std::size_t i = 0; i < world.size(); ++i) {
    const Eigen::Vector3i v = (world.points[i].cast<double>() / config_.voxel).array().floor().cast<int>();
    const bool outside = (v.array().abs() > kLimit).any();
    if (outside || (keys_.size() >= config_.max_points && !keys_.count(voxelKey(v)))) {
      ++dropped_;
      continue;
    }
    if (!keys_.insert(voxelKey(v)).second) continue;
    const ClassInfo* info = classes_.find(world.classes[i]);
    const Rgb color = info && info->kind != PropertyKind::None
                          ? propertyColor(*info, colors_)
                          : greyForHeight(world.points[i].z(), height_range_->first, height_range_->second, colors_);
    fresh.push_back({v, world.classes[i], color});
  }
  std::stable_sort(fresh.begin(), fresh.end(), [](const NewVoxel& a, const NewVoxel& b) { return a.label < b.label; });
  std::vector<std::string> messages;
  for (std::size_t at = 0; at < fresh.size(); at += config_.chunk_points) {
    const std::vector<NewVoxel> chunk(fresh.begin() + std::ptrdiff_t(at),
                                      fresh.begin() + std::ptrdiff_t(std::min(fresh.size(), at + config_.chunk_points)));
    messages.push_back(mapMessage(messages_++, chunk, config_.voxel, classes_, colors_));
  }
  return messages;
}

}  // namespace hazmap
