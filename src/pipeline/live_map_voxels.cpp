#include "hazmap/pipeline/live_map_voxels.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "map/viewer_data.hpp"

namespace hazmap {

namespace {

using nlohmann::json;

template <typename T>
void appendLittleEndian(std::vector<std::uint8_t>& out, T value) {
  for (std::size_t k = 0; k < sizeof(T); ++k) out.push_back(std::uint8_t((std::uint64_t(value) >> (8 * k)) & 0xff));
}

void appendFloat(std::vector<std::uint8_t>& out, double value) {
  const float f = float(value);
  std::uint32_t bits = 0;
  std::memcpy(&bits, &f, sizeof bits);
  appendLittleEndian(out, bits);
}

// 21 bits per axis, offset to unsigned: one 64-bit key per voxel.
std::uint64_t voxelKey(const Eigen::Vector3i& v) {
  const auto u = [](int c) { return std::uint64_t(std::uint32_t(c + (1 << 20)) & 0x1fffff); };
  return u(v.x()) | u(v.y()) << 21 | u(v.z()) << 42;
}

Eigen::Vector3i voxelOf(const Eigen::Vector3d& p, double voxel) { return (p / voxel).array().floor().cast<int>(); }

struct NewVoxel {
  Eigen::Vector3i index;
  ClassId label;
  Rgb color;
};

std::string cssColor(const Rgb& c) { return fmt::format("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]); }

json poseArray(const Eigen::Isometry3d& pose) {
  const Eigen::Vector3d t = pose.translation();
  const Eigen::Quaterniond q(pose.linear());
  return json::array({t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()});
}

/// One "map" message of voxels already grouped by class, all of one segment.
std::string mapMessage(std::size_t seq, std::uint32_t segment, const Eigen::Isometry3d& pose,
                       const std::vector<NewVoxel>& voxels, double voxel, const ClassTable& classes,
                       const MapColorConfig& colors) {
  json groups = json::array();
  std::vector<std::uint8_t> positions, rgb;
  positions.reserve(voxels.size() * 6);
  rgb.reserve(voxels.size() * 3);
  for (const NewVoxel& v : voxels) {
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
              {"segment", segment},
              {"pose", poseArray(pose)},
              {"groups", groups},
              {"xyz", viewer::base64(positions.data(), positions.size())},
              {"rgb", viewer::base64(rgb.data(), rgb.size())}}
      .dump();
}

/// How far the move from `before` to `after` takes a point `range` m from the anchor, at most.
double displacement(const Eigen::Isometry3d& before, const Eigen::Isometry3d& after, double range) {
  const Eigen::Isometry3d delta = before.inverse() * after;
  return delta.translation().norm() + Eigen::AngleAxisd(delta.linear()).angle() * range;
}

}  // namespace

std::string liveAnchorsMessage(const std::vector<std::uint32_t>& segments, const std::vector<Eigen::Isometry3d>& poses) {
  std::vector<std::uint8_t> ids, values;
  ids.reserve(4 * segments.size());
  values.reserve(28 * segments.size());
  for (std::size_t i = 0; i < segments.size(); ++i) {
    appendLittleEndian(ids, segments[i]);
    const Eigen::Vector3d t = poses[i].translation();
    const Eigen::Quaterniond q(poses[i].linear());
    for (double v : {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}) appendFloat(values, v);
  }
  return json{{"type", "anchors"},
              {"count", segments.size()},
              {"segments", viewer::base64(ids.data(), ids.size())},
              {"poses", viewer::base64(values.data(), values.size())}}
      .dump();
}

LiveMapVoxels::LiveMapVoxels(ClassTable classes, LiveMapConfig config, MapColorConfig colors)
    : classes_(std::move(classes)), config_(config), colors_(colors) {}

std::uint32_t LiveMapVoxels::segmentFor(std::size_t frame, const Eigen::Isometry3d& pose) {
  if (open_) {
    const Eigen::Isometry3d from_anchor = segments_[*open_].pose.inverse() * pose;
    const double angle = Eigen::AngleAxisd(from_anchor.linear()).angle() * 180.0 / M_PI;
    if (from_anchor.translation().norm() <= config_.segment_length && angle <= config_.segment_angle_deg) return *open_;
  }
  segments_.push_back({frame, pose});
  open_ = std::uint32_t(segments_.size() - 1);
  return *open_;
}

std::vector<std::string> LiveMapVoxels::add(std::size_t frame, const LabeledCloud& scan,
                                            const Eigen::Isometry3d& T_world_sensor) {
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
    const Eigen::Vector3i v = voxelOf(world.points[i].cast<double>(), config_.voxel);
    const bool outside = (v.array().abs() > kLimit).any();
    if (outside || (points_.size() + fresh.size() >= config_.max_points && !keys_.count(voxelKey(v)))) {
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
  if (fresh.empty()) return {};
  const std::uint32_t segment = segmentFor(frame, T_world_sensor);
  const Eigen::Isometry3d anchor = segments_[segment].pose;  // the page's pose of the segment
  const Eigen::Isometry3d to_anchor = anchor.inverse();
  for (const NewVoxel& v : fresh)
    points_.push_back({(to_anchor * ((v.index.cast<double>().array() + 0.5).matrix() * config_.voxel)).cast<float>(),
                       segment});
  std::stable_sort(fresh.begin(), fresh.end(), [](const NewVoxel& a, const NewVoxel& b) { return a.label < b.label; });
  std::vector<std::string> messages;
  for (std::size_t at = 0; at < fresh.size(); at += config_.chunk_points) {
    const std::vector<NewVoxel> chunk(fresh.begin() + std::ptrdiff_t(at),
                                      fresh.begin() + std::ptrdiff_t(std::min(fresh.size(), at + config_.chunk_points)));
    messages.push_back(mapMessage(messages_++, segment, anchor, chunk, config_.voxel, classes_, colors_));
  }
  return messages;
}

std::string LiveMapVoxels::reanchor(const std::vector<Eigen::Isometry3d>& poses) {
  std::vector<std::uint32_t> moved;
  std::vector<Eigen::Isometry3d> moved_to;
  for (std::uint32_t s = 0; s < segments_.size(); ++s) {
    Segment& segment = segments_[s];
    if (segment.frame >= poses.size()) continue;
    const Eigen::Isometry3d& now = poses[segment.frame];
    if (displacement(segment.pose, now, config_.tolerance_range) <= config_.anchor_tolerance) continue;
    segment.pose = now;
    moved.push_back(s);
    moved_to.push_back(now);
  }
  if (moved.empty()) return {};
  rekey();
  return liveAnchorsMessage(moved, moved_to);
}

// The voxels already drawn are where the moved points are now: a new scan fills what they left.
void LiveMapVoxels::rekey() {
  keys_.clear();
  for (const Point& p : points_)
    keys_.insert(voxelKey(voxelOf(segments_[p.segment].pose * p.local.cast<double>(), config_.voxel)));
}

std::string LiveMapVoxels::anchorsMessage() const {
  if (segments_.empty()) return {};
  std::vector<std::uint32_t> ids(segments_.size());
  std::vector<Eigen::Isometry3d> poses;
  poses.reserve(segments_.size());
  for (std::uint32_t s = 0; s < segments_.size(); ++s) {
    ids[s] = s;
    poses.push_back(segments_[s].pose);
  }
  return liveAnchorsMessage(ids, poses);
}

std::vector<Eigen::Vector3d> LiveMapVoxels::drawnPoints() const {
  std::vector<Eigen::Vector3d> out;
  out.reserve(points_.size());
  for (const Point& p : points_) out.push_back(segments_[p.segment].pose * p.local.cast<double>());
  return out;
}

}  // namespace hazmap
