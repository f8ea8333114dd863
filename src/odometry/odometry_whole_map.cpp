// Whole-map re-localisation of a kidnapped robot (issue 19): after several consecutive frames
// that nothing verified, the scan is registered without a guess against the keyframes — verified
// frames kept along the route, their scans placed at their current poses (reanchor() moves them
// with the pose graph) — by the same global registration as the local recovery, verified by the
// tracking ICP against the same keyframes. Unlike the local recovery there is no bound on the
// motion (the robot may have been carried anywhere); instead the answer must fit the keyframes
// well, better than the guess does, and the global registration must not be ambiguous.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/registration/global_registration.hpp"
#include "odometry/odometry_checks.hpp"

namespace hazmap {

struct WholeMap {
  GlobalRegistrationTarget global;
  std::unique_ptr<RegistrationTarget> icp;
  std::size_t keyframes = 0, points = 0;
};

void Odometry::keepKeyframe(const OdometryFrame& f, const LabeledCloud& frame) {
  if (!config_.recovery.relocalise || !config_.recovery.whole_map || frame.empty()) return;
  if (f.status != FrameStatus::First && f.status != FrameStatus::Tracked && f.status != FrameStatus::Relocalised)
    return;  // a flagged frame's pose is (partly) a guess
  auto& keyframes = impl_->keyframes;
  if (!keyframes.empty()) {
    const Eigen::Isometry3d d = frames_.pose(keyframes.back().frame).inverse() * f.pose;
    if (translationNorm(d) < config_.recovery.keyframe_distance && rotationAngle(d) < config_.recovery.keyframe_rotation) return;
  }
  keyframes.push_back({f.index, frame});
  // Memory stays bounded on a long mission: the oldest resident scan goes to disk.
  if (keyframes.size() <= config_.recovery.resident_keyframes) return;
  Impl::Keyframe& oldest = keyframes[keyframes.size() - 1 - config_.recovery.resident_keyframes];
  if (!impl_->keyframe_spill) impl_->keyframe_spill.emplace();
  impl_->keyframe_spill->store(oldest.frame, oldest.scan);
  oldest.scan = LabeledCloud();
  oldest.on_disk = true;
}

std::size_t Odometry::keyframes() const { return impl_->keyframes.size(); }

std::size_t Odometry::residentKeyframes() const {
  return static_cast<std::size_t>(std::count_if(impl_->keyframes.begin(), impl_->keyframes.end(),
                                                [](const Impl::Keyframe& k) { return !k.on_disk; }));
}

// The keyframes in the world at their current poses, downsampled to the scan's voxel size, with
// the global registration's features (normals oriented towards the keyframes' mean position: the
// map is seen from inside) and the tracking ICP's target. Kept until keyframes are added or moved.
// `scan_of(k, holder)`: keyframe k's scan (Impl::keyframeScan).
template <class Keyframes, class ScanOf>
static std::shared_ptr<const WholeMap> buildWholeMap(const Keyframes& keyframes, const ScanOf& scan_of,
                                                     const FrameHistory& frames,
                                                     const OdometryConfig& config, const ClassTable& classes) {
  LabeledCloud all, holder;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    const Eigen::Isometry3d& pose = frames.pose(keyframes[k].frame);
    all.append(scan_of(k, holder).transformed(pose));
    centre += pose.translation();
  }
  centre /= static_cast<double>(keyframes.size());
  LabeledCloud cloud = voxelDownsample(all, propertyVoxels(config.voxel_size), classes);
  auto map = std::make_shared<WholeMap>();
  map->keyframes = keyframes.size();
  map->points = cloud.size();
  map->global = prepareGlobalTarget(cloud, classes, globalConfigOf(config), centre.cast<float>());
  map->icp = std::make_unique<RegistrationTarget>(std::move(cloud), classes, config.registration);
  return map;
}

// The previous frame's whole-map answer and this one are a plausible motion apart (a single scan
// can look like another place: naraha without odometry, 27.8 m / 127 deg off with surface fit
// 0.71). Remembers this answer for the next frame either way.
bool Odometry::confirmed(const Eigen::Isometry3d& answer, std::size_t frame) {
  const bool agrees = impl_->whole_map_candidate && impl_->whole_map_candidate_frame + 1 == frame &&
                      plausibleMotion(impl_->whole_map_candidate->inverse() * answer, config_);
  impl_->whole_map_candidate = answer;
  impl_->whole_map_candidate_frame = frame;
  return agrees;
}

std::optional<RegistrationResult> Odometry::relocaliseInWholeMap(OdometryFrame& f, const LabeledCloud& source,
                                                                 const Eigen::Isometry3d& world_guess) {
  const auto t = Clock::now();
  char buf[256];
  std::snprintf(buf, sizeof buf, "%zu consecutive frames not verified", impl_->fallback_streak + 1);
  if (f.global.trigger.empty()) f.global.trigger = buf;
  else f.global.trigger += std::string("; ") + buf;
  std::string& outcome = f.global.outcome;
  outcome += outcome.empty() ? "whole map: " : "; whole map: ";
  if (impl_->keyframes.empty()) {
    outcome += "no keyframes yet";
    return std::nullopt;
  }
  if (!impl_->whole_map || impl_->whole_map_keyframes != impl_->keyframes.size() ||
      impl_->whole_map_version != impl_->reanchors) {
    const auto scan_of = [this](std::size_t k, LabeledCloud& holder) -> const LabeledCloud& {
      return impl_->keyframeScan(k, classes_, holder);
    };
    impl_->whole_map = buildWholeMap(impl_->keyframes, scan_of, frames_, config_, classes_);
    impl_->whole_map_keyframes = impl_->keyframes.size();
    impl_->whole_map_version = impl_->reanchors;
  }
  const WholeMap& map = *impl_->whole_map;
  const GlobalRegistrationResult g = registerGlobally(source, map.global, classes_, globalConfigOf(config_));
  f.global.tried = f.global.whole_map = true;
  f.global.status = g.status;
  f.global.score = g.score;
  f.global.second_best_score = g.second_best_score;
  std::optional<RegistrationResult> verified = std::nullopt;
  if (!g.success || g.ambiguous) {
    outcome += g.reason.empty() ? std::string(toString(g.status)) : g.reason;
  } else {
    RegistrationResult r = registerClouds(source, *map.icp, g.transform, classes_, config_.registration);
    std::string why = registrationFailure(r, g.transform, config_);
    const double fit = surfaceFit(source, *map.icp, r.transform, kSurfaceInlierDistance);
    const double guess_fit = surfaceFit(source, *map.icp, world_guess, kSurfaceInlierDistance);
    if (why.empty() && !r.degenerate_directions.empty()) why = "degenerate";
    // Along a weakly constrained axis (a corridor) any place along it fits: no proof of where.
    if (why.empty() && weakHorizontalAxis(r, kSuspectWeakAxisRatio)) why = "weakly constrained along an axis";
    if (why.empty() && fitsWorseThanTracked(r, impl_->typical_rmse))
      why = "inlier RMSE above that of tracked frames";
    if (why.empty() && fit < kWholeMapMinFit) why = "fits poorly";
    if (why.empty() && fit < guess_fit + kRecoveryMinGain) why = "fits no better than the guess";
    const Eigen::Isometry3d jump = world_guess.inverse() * r.transform;
    std::snprintf(buf, sizeof buf, "%s against %zu keyframes (surface fit %.3f, guess %.3f; %.2f m / %.1f deg from the guess)",
                  why.empty() ? "re-localised" : why.c_str(), map.keyframes, fit, guess_fit, translationNorm(jump),
                  rotationAngle(jump) * 180.0 / M_PI);
    outcome += buf;
    if (why.empty() && !confirmed(r.transform, f.index)) outcome += "; awaiting the next frame's confirmation";
    else if (why.empty()) verified = std::move(r);
  }
  f.global.milliseconds += msSince(t);
  return verified;
}

// After a whole-map re-localisation the local map holds the scans placed while the robot was
// lost: it is rebuilt from the keyframes (one integrate() per frame so far, empty for the
// others, so reanchor()'s scan i stays frame i).
void Odometry::rebuildLocalMapFromKeyframes(const Eigen::Isometry3d& pose) {
  map_.clear();
  std::size_t k = 0;
  const auto& keyframes = impl_->keyframes;
  LabeledCloud holder;
  for (std::size_t i = 0; i < frames_.size(); ++i) {
    const bool keyframe = k < keyframes.size() && keyframes[k].frame == i;
    map_.integrate(keyframe ? impl_->keyframeScan(k, classes_, holder).transformed(frames_.pose(i)) : LabeledCloud(),
                   pose.translation(), classes_);
    k += keyframe;
  }
}

}  // namespace hazmap
