#include "pipeline/map_folder_output.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "hazmap/core/config_fields.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/loop/landmarks.hpp"
#include "pipeline/prior_overview.hpp"

namespace hazmap::pipeline_detail {

std::vector<std::size_t> keyframeFrames(const SlamResult& result, const SlamConfig& config) {
  std::vector<std::size_t> frames;
  const auto& poses = result.tracked.poses.empty() ? result.estimate.poses : result.tracked.poses;
  Eigen::Isometry3d last = Eigen::Isometry3d::Identity();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!frames.empty()) {
      const Eigen::Isometry3d since = last.inverse() * poses[i];
      if (translationNorm(since) < config.keyframe_distance && rotationAngle(since) < config.keyframe_angle) continue;
    }
    frames.push_back(i);
    last = poses[i];
  }
  return frames;
}

MapFolderOutput::MapFolderOutput(std::filesystem::path dir, const SlamResult& result, const SlamConfig& config,
                                 const ClassTable& classes)
    : dir_(std::move(dir)), result_(result), config_(config), classes_(classes),
      keyframes_(keyframeFrames(result, config)),
      search_classes_(config.property_icp.applyTo(classes, dir_.string())), overview_(search_classes_) {
  invalidateMapFolder(dir_);
  manifest_.method = toString(result.method);
  manifest_.source = result.source;
  manifest_.frames = result.estimate.size();
}

void MapFolderOutput::addScan(std::size_t frame, const LabeledCloud& scan) {
  if (next_ >= keyframes_.size() || keyframes_[next_] != frame) return;
  ++next_;
  MapKeyframe k;
  k.frame = frame;
  k.stamp = result_.estimate.stamps.at(frame);
  k.pose = result_.estimate.poses.at(frame);
  k.points = scan.size();
  k.cloud = writeMapKeyframeCloud(dir_, frame, scan);
  overview_.add(keyframeOverview(scan, search_classes_), k.pose);
  k.landmarks = extractLandmarks(scan, classes_, config_.loop_closure.landmarks);
  heights_.push_back(sensorHeightAboveFloor(scan));
  manifest_.keyframes.push_back(std::move(k));
}

void MapFolderOutput::finish() {
  std::vector<double> h;
  for (double v : heights_)
    if (std::isfinite(v)) h.push_back(v);
  manifest_.sensor_height = std::numeric_limits<double>::quiet_NaN();
  if (!h.empty()) {
    std::nth_element(h.begin(), h.begin() + static_cast<std::ptrdiff_t>(h.size() / 2), h.end());
    manifest_.sensor_height = h[h.size() / 2];
  }
  manifest_.parameters_json = configToJson(config_).dump();
  const std::string extras = writeGraphExtras(dir_, result_.graph);
  // What a later mission's localisation in this map would otherwise rebuild from every keyframe.
  manifest_.search_overview = writeSearchOverview(dir_, overview_.finish(), search_classes_);
  writeMapManifest(dir_, manifest_, classes_, {"graph.g2o", "trajectory.kitti", "hazards.json"}, extras);
}

}  // namespace hazmap::pipeline_detail
