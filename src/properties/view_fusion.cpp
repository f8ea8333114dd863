#include "hazmap/properties/view_fusion.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "hazmap/core/error.hpp"
#include "hazmap/core/voxel_key.hpp"

namespace hazmap {

void ViewFusionConfig::validate(const std::string& where) const {
  if (!(voxel > 0) || !std::isfinite(voxel)) fail(where, "view fusion voxel must be > 0");
  if (!(window >= 0) || !std::isfinite(window)) fail(where, "view fusion window must be >= 0");
  if (!(calibration_uncertainty_deg >= 0) || !std::isfinite(calibration_uncertainty_deg))
    fail(where, "view fusion calibration_uncertainty_deg must be >= 0");
  if (!(odometry_drift >= 0) || !std::isfinite(odometry_drift)) fail(where, "view fusion odometry_drift must be >= 0");
}

namespace {

constexpr std::uint8_t kAnyFacing = 3;
constexpr std::size_t kCachedImages = 64;

/// The world axis a normal is closest to (0 x, 1 y, 2 z), kAnyFacing without a normal.
std::uint8_t facing(const Eigen::Vector3f& normal_scan, const Eigen::Matrix3d& R_world_scan) {
  if (normal_scan.squaredNorm() < 0.5f) return kAnyFacing;
  const Eigen::Vector3d n = (R_world_scan * normal_scan.cast<double>()).cwiseAbs();
  std::uint8_t axis = 0;
  for (std::uint8_t a = 1; a < 3; ++a)
    if (n[a] > n[axis]) axis = a;
  return axis;
}

}  // namespace

ViewFusion::ViewFusion(const PropertyLabeler& labeler, ViewFusionConfig config) : labeler_(labeler), config_(config) {
  config_.validate("view fusion");
}

bool ViewFusion::key(const Eigen::Vector3d& world, std::uint64_t& out) const {
  std::int64_t c[3];
  for (int a = 0; a < 3; ++a)
    if (!voxelCoordinate(world[a] / config_.voxel, c[a])) return false;
  return voxelKey(c[0], c[1], c[2], out);
}

void ViewFusion::add(std::size_t frame, const LabeledCloud& scan, const Eigen::Isometry3d& T_world_scan,
                     double travelled, const ScanLabels& labels) {
  const std::size_t channels = labeler_.channels().size();
  if (frame != frames_.size()) fail("view fusion", "frames must be added in order");
  if (labels.channels.size() != channels || labels.footprint.size() != channels || labels.normals.size() != scan.size())
    fail("view fusion", "labels need one channel and one footprint row per channel, and normals");
  frames_.push_back({T_world_scan, travelled, labels.image_index, labels.T_camera_scan});
  const Eigen::Matrix3d R = T_world_scan.linear();
  // The camera of each channel's view: its only camera, or per point the rig's (source_camera).
  std::vector<std::uint8_t> first_camera(channels, 0);
  for (std::size_t c = labeler_.cameras().size(); c-- > 0;)
    first_camera[static_cast<std::size_t>(labeler_.cameraChannel(c))] = static_cast<std::uint8_t>(c);
  const auto cameraOf = [&](std::size_t ch, std::size_t i) {
    return ch < labels.source_camera.size() && !labels.source_camera[ch].empty() ? labels.source_camera[ch][i]
                                                                                 : first_camera[ch];
  };
  for (std::size_t i = 0; i < scan.size(); ++i) {
    std::uint64_t k = 0;
    bool keyed = false;
    for (std::size_t c = 0; c < channels; ++c) {
      if (std::isnan(labels.channels[c][i])) continue;
      if (!keyed && !(keyed = key(T_world_scan * scan.points[i].cast<double>(), k))) break;
      const float fp = labels.footprint[c][i];
      views_[k].push_back({static_cast<float>(travelled), std::isnan(fp) ? std::numeric_limits<float>::max() : fp,
                           static_cast<std::uint32_t>(frame), static_cast<std::uint16_t>(c), facing(labels.normals[i], R),
                           cameraOf(c, i)});
      ++observations_;
    }
  }
}

std::vector<std::int32_t> ViewFusion::bestFrames(std::size_t frame, const LabeledCloud& scan) const {
  const std::size_t channels = labeler_.channels().size();
  const auto cameras = static_cast<std::uint32_t>(labeler_.cameras().size());
  const Placement& here = frames_.at(frame);
  const float window = static_cast<float>(config_.window), at = static_cast<float>(here.travelled);
  const std::vector<Eigen::Vector3f> normals = estimateNormals(scan, config_.normals);
  const Eigen::Matrix3d R = here.T_world_scan.linear();
  std::vector<std::int32_t> best(scan.size() * channels, -1);
  const float angle = static_cast<float>(config_.calibration_uncertainty_deg * M_PI / 180.0);
  const float drift = static_cast<float>(config_.odometry_drift);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    std::uint64_t k = 0;
    if (!key(here.T_world_scan * scan.points[i].cast<double>(), k)) continue;
    const auto it = views_.find(k);
    if (it == views_.end()) continue;
    const std::uint8_t face = facing(normals[i], R);
    for (std::size_t ch = 0; ch < channels; ++ch) {
      // The cheapest view (first of equal costs wins: deterministic).
      float best_cost = std::numeric_limits<float>::infinity();
      std::int32_t pick = -1;
      for (const View& v : it->second) {
        if (v.channel != ch) continue;
        const float travel = std::abs(v.travelled - at);
        if (travel > window) continue;
        if (face != kAnyFacing && v.facing != kAnyFacing && v.facing != face) continue;
        const float cost = v.footprint * angle + drift * travel;
        if (cost < best_cost) {
          best_cost = cost;
          pick = static_cast<std::int32_t>(v.frame * cameras + v.camera);
        }
      }
      best[i * channels + ch] = pick;
    }
  }
  return best;
}

const PropertyImage& ViewFusion::image(std::size_t camera, long index) {
  const auto key = std::make_pair(camera, index);
  if (const auto it = cache_.find(key); it != cache_.end()) return it->second;
  if (cache_.size() >= kCachedImages) cache_.clear();  // frames come in order: the window moves on
  const CameraInput& input = labeler_.cameras()[camera];
  return cache_.emplace(key, input.images->load(static_cast<std::size_t>(index), input.camera)).first->second;
}

bool ViewFusion::sample(std::size_t camera, const Placement& view, const Eigen::Vector3d& world, float& value,
                        float& low, float& high) {
  const long index = view.image_index.at(camera);
  if (index < 0) return false;
  const Eigen::Vector3d p = view.T_camera_scan[camera] * (view.T_world_scan.inverse() * world);
  if (!(p.z() > labeler_.config().projection.min_depth)) return false;
  const CameraModel& model = labeler_.cameras()[camera].camera.model;
  const auto px = model.projectUnbounded(p);
  if (!px || !model.inImage(*px)) return false;
  const PropertyImage& img = image(camera, index);
  value = sampleBilinear(img, static_cast<float>(px->x()), static_cast<float>(px->y()));
  if (!std::isfinite(value)) return false;
  if (const int r = labeler_.config().projection.edge_guard_px; r > 0)
    pixelRange(img, static_cast<float>(px->x()), static_cast<float>(px->y()), r, low, high);
  return true;
}

void ViewFusion::fuse(std::size_t frame, const LabeledCloud& scan, const std::vector<std::int32_t>& best,
                      ScanLabels& labels) {
  const std::size_t channels = labeler_.channels().size();
  if (labels.channels.size() != channels) fail("view fusion", "labels need one channel row per channel");
  const bool guard = labels.low.size() == channels && labels.high.size() == channels;
  if (best.size() != scan.size() * channels) fail("view fusion", "best views need one entry per point and channel");
  const Placement& here = frames_[frame];
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::int32_t cameras = static_cast<std::int32_t>(labeler_.cameras().size());
  for (std::size_t i = 0; i < scan.size(); ++i)
    for (std::size_t ch = 0; ch < channels; ++ch) {
      const std::int32_t view = best[i * channels + ch];
      const std::int32_t f = view < 0 ? -1 : view / cameras;
      // Its own scan's view is the best: kept (observe chose the same camera, by the same cost).
      if (f == static_cast<std::int32_t>(frame)) continue;
      float value = nan, low = nan, high = nan;
      if (f >= 0) {
        const Eigen::Vector3d world = here.T_world_scan * scan.points[i].cast<double>();
        // The view's camera, else the channel's first other camera of that scan that sees it.
        const std::size_t picked = static_cast<std::size_t>(view % cameras);
        if (!sample(picked, frames_[f], world, value, low, high))
          for (std::size_t c = 0; c < labeler_.cameras().size(); ++c)
            if (c != picked && static_cast<std::size_t>(labeler_.cameraChannel(c)) == ch &&
                sample(c, frames_[f], world, value, low, high))
              break;
      }
      labels.channels[ch][i] = value;
      if (guard) {
        labels.low[ch][i] = low;
        labels.high[ch][i] = high;
      }
    }
}

std::vector<double> travelledDistance(const Trajectory& trajectory) {
  const auto& poses = trajectory.poses;
  std::vector<double> out(poses.size(), 0.0);
  for (std::size_t i = 1; i < poses.size(); ++i)
    out[i] = out[i - 1] + (poses[i].translation() - poses[i - 1].translation()).norm();
  return out;
}

}  // namespace hazmap
