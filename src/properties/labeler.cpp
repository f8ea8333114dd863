#include "hazmap/properties/labeler.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <unordered_set>

#include "hazmap/core/error.hpp"
#include "hazmap/core/voxel_key.hpp"
#include "hazmap/preprocess/spatial_index.hpp"

namespace hazmap {

void MemoryImages::add(PropertyImage image) {
  if (!stamps_.empty() && image.stamp < stamps_.back()) fail("images", "image stamps go back in time");
  stamps_.push_back(image.stamp);
  images_.push_back(std::move(image));
}

void LabelerConfig::validate(const std::string& where) const {
  projection.validate(where);
  if (!(time_tolerance >= 0)) fail(where, "time_tolerance must be >= 0");
}

std::optional<Eigen::Isometry3d> interpolatePose(const Trajectory& trajectory, double t) {
  const auto& s = trajectory.stamps;
  if (s.empty() || t < s.front() || t > s.back() || s.size() != trajectory.poses.size()) return std::nullopt;
  const std::size_t hi = static_cast<std::size_t>(std::lower_bound(s.begin(), s.end(), t) - s.begin());
  if (s[hi] == t || hi == 0) return trajectory.poses[hi];
  const std::size_t lo = hi - 1;
  const double a = (t - s[lo]) / (s[hi] - s[lo]);
  const Eigen::Isometry3d& A = trajectory.poses[lo];
  const Eigen::Isometry3d& B = trajectory.poses[hi];
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(A.linear()).slerp(a, Eigen::Quaterniond(B.linear())).toRotationMatrix();
  T.translation() = (1 - a) * A.translation() + a * B.translation();
  return T;
}

PropertyLabeler::PropertyLabeler(std::vector<CameraInput> cameras, PropertyRules rules, LabelerConfig config)
    : cameras_(std::move(cameras)), rules_(std::move(rules)), config_(config) {
  config_.validate("labeler");
  for (const CameraInput& c : cameras_) {
    if (!c.images) fail(c.camera.source.string(), "camera has no image source");
    const auto it = std::find(channels_.begin(), channels_.end(), c.camera.channel.name);
    camera_channel_.push_back(static_cast<int>(it - channels_.begin()));
    if (it == channels_.end()) channels_.push_back(c.camera.channel.name);
  }
  rules_.checkChannels(channels_, "rules");
}

namespace {

/// Index of the image nearest to `t` within `tolerance`, or -1.
long nearestImage(const std::vector<double>& stamps, double offset, double t, double tolerance) {
  const auto it = std::lower_bound(stamps.begin(), stamps.end(), t - offset);
  long best = -1;
  double best_dt = tolerance;
  for (auto c : {it, it == stamps.begin() ? it : it - 1}) {
    if (c == stamps.end()) continue;
    const double dt = std::abs(*c + offset - t);
    if (dt <= best_dt) {
      best_dt = dt;
      best = static_cast<long>(c - stamps.begin());
    }
  }
  return best;
}

// normal_z where the scan lines lie apart: a point's k nearest neighbours all lie on its own
// scan line (a VLP-16's floor rings are 0.2° dense along and 2° apart across: ~0.3 m apart at
// 2 m range for a sensor 0.5 m up, ~0.6 m at 3 m, ~1.7 m at 5 m), fit no plane, and the point
// got no normal, so a dark floor there could not be `water`. Such a point takes its neighbours
// from a copy of the scan thinned to one point per 0.25 m voxel, within a radius growing with
// range (0.2 × range, 1-4 m), which reaches the next line where it lies that close (to ~4 m
// range for that sensor); farther, only a floor point gets one (fillFloorNormals). Rig seed 6:
// water recall 0.859 → 0.881 (docs/properties.md, "Camera rigs").
void fillSparseNormals(const LabeledCloud& scan, const NormalConfig& config, std::vector<Eigen::Vector3f>& normals) {
  constexpr float kThin = 0.25f, kMinRadius = 1.0f, kMaxRadius = 4.0f, kRangeShare = 0.2f;
  constexpr int kNeighbours = 48;
  if (std::none_of(normals.begin(), normals.end(), [](const Eigen::Vector3f& n) { return n.isZero(); })) return;
  std::vector<Eigen::Vector3f> thin;
  std::unordered_set<std::uint64_t> seen;
  std::array<std::int64_t, 3> voxel;
  std::uint64_t key = 0;
  for (const Eigen::Vector3f& p : scan.points)
    if (voxelOfPoint(p.x() / kThin, p.y() / kThin, p.z() / kThin, voxel, key) && seen.insert(key).second) thin.push_back(p);
  const VoxelHashIndex index(thin, {}, kMaxRadius / 2.0f, kMaxRadius);
  std::vector<Neighbor> near;
  std::vector<Eigen::Vector3f> pts;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (!normals[i].isZero() || !scan.points[i].allFinite()) continue;
    const float r = std::clamp(kRangeShare * scan.points[i].norm(), kMinRadius, kMaxRadius);
    index.kNearest(scan.points[i], kNeighbours, r * r, near);
    pts.clear();
    for (const Neighbor& nb : near) pts.push_back(thin[nb.index]);
    normals[i] = planeNormal(scan.points[i], pts, config);
  }
}

/// Height (along `up`) of the most populated 5 cm band of level surface below the sensor, from
/// the points whose own normal is within ~18° of `up`; nullopt with fewer than `min_support`.
std::optional<float> floorHeight(const LabeledCloud& scan, const Eigen::Vector3f& up,
                                 const std::vector<Eigen::Vector3f>& normals, std::size_t min_support) {
  constexpr float kLevel = 0.95f, kBin = 0.05f, kBelowSensor = -0.1f;
  std::map<long, std::size_t> bins;
  std::size_t level = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const float h = up.dot(scan.points[i]);
    if (normals[i].isZero() || std::abs(normals[i].dot(up)) < kLevel || !(h < kBelowSensor)) continue;
    ++bins[static_cast<long>(std::floor(h / kBin))];
    ++level;
  }
  if (level < min_support) return std::nullopt;
  const auto top = std::max_element(bins.begin(), bins.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  return (static_cast<float>(top->first) + 0.5f) * kBin;
}

// normal_z on the floor beyond the thinned scan's reach (fillSparseNormals): a VLP-16's floor
// rings 9.5 m away lie 3.8 m apart, so a dark puddle there had no normal and could not be
// `water` (rig seed 6, frames 47 and 72). The floor is one plane: fitted to the level points
// near the floor's height, it gives its normal to every point without one that lies on it
// (within 5 cm + 0.5 % of range: the rings' own spread). A point just above the floor at a
// wall's foot gets the floor's normal too; it is floor-high either way.
void fillFloorNormals(const LabeledCloud& scan, const Eigen::Vector3f& up, const NormalConfig& config,
                      std::vector<Eigen::Vector3f>& normals) {
  constexpr std::size_t kMinSupport = 50;
  constexpr float kBand = 0.1f, kMinAlignment = 0.985f, kTolerance = 0.05f, kTolerancePerMetre = 0.005f;
  if (std::none_of(normals.begin(), normals.end(), [](const Eigen::Vector3f& n) { return n.isZero(); })) return;
  const std::optional<float> height = floorHeight(scan, up, normals, kMinSupport);
  if (!height) return;
  std::vector<Eigen::Vector3f> floor;
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (normals[i].isZero() || std::abs(up.dot(scan.points[i]) - *height) > kBand) continue;
    floor.push_back(scan.points[i]);
    centroid += scan.points[i];
  }
  if (floor.size() < kMinSupport) return;
  centroid /= static_cast<float>(floor.size());
  Eigen::Vector3f n = planeNormal(centroid, floor, config);
  if (n.isZero() || std::abs(n.dot(up)) < kMinAlignment) return;  // not a level floor: leave it
  const float offset = n.dot(centroid);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const Eigen::Vector3f& p = scan.points[i];
    if (!normals[i].isZero() || !p.allFinite()) continue;
    if (std::abs(n.dot(p) - offset) < kTolerance + kTolerancePerMetre * p.norm()) normals[i] = n;
  }
}

/// |z| of each point's unit normal in the world frame (NaN where no normal could be fitted).
std::vector<float> normalZ(const LabeledCloud& scan, const Eigen::Matrix3d& R_world_lidar, const NormalConfig& config) {
  std::vector<Eigen::Vector3f> normals = estimateNormals(scan, config);
  fillSparseNormals(scan, config, normals);
  const Eigen::Vector3f up = R_world_lidar.transpose().col(2).cast<float>();  // world z in the LiDAR frame
  fillFloorNormals(scan, up, config, normals);
  std::vector<float> out(scan.size(), std::numeric_limits<float>::quiet_NaN());
  for (std::size_t i = 0; i < normals.size(); ++i)
    if (normals[i].squaredNorm() > 0.5f) out[i] = std::abs(normals[i].dot(up));
  return out;
}

}  // namespace

namespace {

/// Footprints of the points camera `c` just gave a value (finite value, no footprint yet).
void addFootprints(const LabeledCloud& scan, const Eigen::Isometry3d& T_camera_scan, const std::vector<float>& values,
                   const NormalConfig& config, std::unique_ptr<VoxelHashIndex>& index, std::vector<float>& footprint,
                   std::vector<Eigen::Vector3f>& normals) {
  if (!index)
    index = std::make_unique<VoxelHashIndex>(scan.points, std::span<const std::uint32_t>{},
                                             static_cast<float>(config.radius) * 0.5f, static_cast<float>(config.radius));
  const Eigen::Vector3f centre = T_camera_scan.inverse().translation().cast<float>();
  // Beyond ~87° of incidence the footprint is capped: the surface is seen edge-on either way.
  constexpr float kMinCos = 0.05f;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isnan(footprint[i]) || std::isnan(values[i])) continue;
    const Eigen::Vector3f ray = scan.points[i] - centre;
    const float range = ray.norm();
    if (normals[i].isZero()) normals[i] = normalAt(scan.points, *index, i, config);
    const Eigen::Vector3f& n = normals[i];
    const float cosine = n.squaredNorm() > 0.5f ? std::abs(n.dot(ray)) / std::max(range, 1e-6f) : 0.0f;
    footprint[i] = range / std::max(cosine, kMinCos);
  }
}

}  // namespace

ScanLabels PropertyLabeler::label(const LabeledCloud& scan, double time, const PoseAtTime& pose_at) const {
  ScanLabels out = observe(scan, time, pose_at);
  classify(scan, pose_at ? pose_at(time) : std::nullopt, out);
  return out;
}

ScanLabels PropertyLabeler::observe(const LabeledCloud& scan, double time, const PoseAtTime& pose_at) const {
  ScanLabels out;
  const std::size_t n = scan.size();
  const std::vector<float> nan_row(n, std::numeric_limits<float>::quiet_NaN());
  out.channels.assign(channels_.size(), nan_row);
  out.in_view.assign(n, 0);
  if (config_.projection.edge_guard_px > 0) out.low = out.high = out.channels;
  if (config_.footprints) {
    out.footprint = out.channels;
    out.normals.assign(n, Eigen::Vector3f::Zero());
  }
  std::unique_ptr<VoxelHashIndex> index;  // built on the first footprint asked for
  const std::optional<Eigen::Isometry3d> T_world_scan = pose_at ? pose_at(time) : std::nullopt;
  ProjectionScratch scratch;
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    const CameraCalibration& cam = cameras_[c].camera;
    const long k = nearestImage(cameras_[c].images->stamps(), cam.time_offset, time, config_.time_tolerance);
    out.image_index.push_back(k);
    out.T_camera_scan.push_back(cam.T_camera_lidar);
    if (k < 0) {
      ++out.images_missing;
      continue;
    }
    const PropertyImage image = cameras_[c].images->load(static_cast<std::size_t>(k), cam);
    Eigen::Isometry3d T_camera_scan = cam.T_camera_lidar;
    if (config_.motion_compensation && T_world_scan) {
      const double t_image = image.stamp + cam.time_offset;
      if (const auto T_world_image = pose_at(t_image)) T_camera_scan = cam.T_camera_lidar * T_world_image->inverse() * *T_world_scan;
    }
    out.T_camera_scan.back() = T_camera_scan;
    observeCamera(c, scan, image, T_camera_scan, scratch, index, out);
    ++out.images_used;
  }
  return out;
}

std::size_t PropertyLabeler::camerasOfChannel(std::size_t ch) const {
  return static_cast<std::size_t>(std::count(camera_channel_.begin(), camera_channel_.end(), static_cast<int>(ch)));
}

void PropertyLabeler::observeCamera(std::size_t c, const LabeledCloud& scan, const PropertyImage& image,
                                    const Eigen::Isometry3d& T_camera_scan, ProjectionScratch& scratch,
                                    std::unique_ptr<VoxelHashIndex>& index, ScanLabels& out) const {
  const CameraCalibration& cam = cameras_[c].camera;
  const int ch = camera_channel_[c];
  const bool guard = out.low.size() == channels_.size();
  const auto span = [](std::vector<std::vector<float>>& rows, int k, bool on) {
    return on ? std::span<float>(rows[static_cast<std::size_t>(k)]) : std::span<float>();
  };
  if (camerasOfChannel(static_cast<std::size_t>(ch)) == 1) {  // the channel's own camera: straight in
    out.projection += projectIntoImage(scan.points, T_camera_scan, cam.model, image, config_.projection, out.channels[ch],
                                       out.in_view, &scratch, span(out.low, ch, guard), span(out.high, ch, guard));
    if (config_.footprints)
      addFootprints(scan, T_camera_scan, out.channels[ch], config_.normals, index, out.footprint[ch], out.normals);
    return;
  }
  // A rig: this camera's view into rows of its own, then per point the camera whose view has the
  // smallest footprint (view fusion's cost within one scan), else the first camera that saw it.
  const std::size_t n = scan.size();
  if (out.source_camera.size() != channels_.size()) out.source_camera.resize(channels_.size());
  auto& source = out.source_camera[static_cast<std::size_t>(ch)];
  if (source.empty()) source.assign(n, 0);
  std::vector<std::vector<float>> rows(4, std::vector<float>(n, std::numeric_limits<float>::quiet_NaN()));
  out.projection += projectIntoImage(scan.points, T_camera_scan, cam.model, image, config_.projection, rows[0],
                                     out.in_view, &scratch, span(rows, 1, guard), span(rows, 2, guard));
  if (config_.footprints) addFootprints(scan, T_camera_scan, rows[0], config_.normals, index, rows[3], out.normals);
  for (std::size_t i = 0; i < n; ++i) {
    if (std::isnan(rows[0][i])) continue;
    const bool empty = std::isnan(out.channels[ch][i]);
    if (!empty && !(config_.footprints && rows[3][i] < out.footprint[ch][i])) continue;
    out.channels[ch][i] = rows[0][i];
    if (guard) out.low[ch][i] = rows[1][i], out.high[ch][i] = rows[2][i];
    if (config_.footprints) out.footprint[ch][i] = rows[3][i];
    source[i] = static_cast<std::uint8_t>(c);
  }
}

void PropertyLabeler::classify(const LabeledCloud& scan, const std::optional<Eigen::Isometry3d>& T_world_scan,
                               ScanLabels& out) const {
  const std::size_t n = scan.size();
  const bool guard = out.low.size() == channels_.size() && out.high.size() == channels_.size();
  // Rule variables per point: channels by name, normal_z computed only when asked for.
  const auto& vars = rules_.variables();
  std::vector<const std::vector<float>*> sources(vars.size(), nullptr), lows(vars.size()), highs(vars.size());
  std::vector<float> nz;
  for (std::size_t v = 0; v < vars.size(); ++v) {
    if (vars[v] == "normal_z") {
      if (nz.empty()) nz = normalZ(scan, T_world_scan ? Eigen::Matrix3d(T_world_scan->linear()) : Eigen::Matrix3d::Identity(), config_.normals);
      sources[v] = lows[v] = highs[v] = &nz;
    } else {
      const auto ch = std::find(channels_.begin(), channels_.end(), vars[v]) - channels_.begin();
      sources[v] = &out.channels[ch];
      lows[v] = guard ? &out.low[ch] : sources[v];
      highs[v] = guard ? &out.high[ch] : sources[v];
    }
  }
  out.classes.assign(n, 0);
  std::vector<float> values(vars.size());
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t v = 0; v < vars.size(); ++v) values[v] = (*sources[v])[i];
    ClassId c = rules_.classify(values.data());
    // Edge guard: a hazard class that the darkest or brightest pixel nearby would not give is
    // left out — a calibration error of that many pixels could have made it.
    if (guard && c != 0) {
      const auto at = [&](const std::vector<float>* range, std::size_t v) {
        const float x = (*range)[i];
        return std::isnan(x) ? (*sources[v])[i] : x;  // no range where another camera gave the value
      };
      for (std::size_t v = 0; v < vars.size(); ++v) values[v] = at(lows[v], v);
      if (rules_.classify(values.data()) != c) c = 0;
      for (std::size_t v = 0; v < vars.size(); ++v) values[v] = at(highs[v], v);
      if (rules_.classify(values.data()) != c) c = 0;
    }
    out.classes[i] = c;
  }
}

void PropertyLabeler::apply(const ScanLabels& labels, LabeledCloud& scan) {
  scan.classes = labels.classes;
  if (!labels.channels.empty()) {
    scan.enableProperty();
    scan.property = labels.channels.front();
  }
}

}  // namespace hazmap
