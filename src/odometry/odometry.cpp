#include "hazmap/odometry/odometry.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>
#include <tbb/parallel_invoke.h>

#include "hazmap/core/error.hpp"
#include "hazmap/preprocess/crop.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/registration/covariance.hpp"
#include "hazmap/registration/registration_target.hpp"
#include "odometry/frame_judgement.hpp"
#include "odometry/odometry_checks.hpp"

namespace hazmap {

Odometry::Odometry(const ClassTable& classes, const OdometryConfig& config,
                   const Eigen::Isometry3d& initial_pose)
    : classes_(classes), config_(config), initial_pose_(initial_pose), map_(config.map),
      impl_(std::make_unique<Impl>()) {
  config_.validate();
  if (!isFinite(initial_pose)) fail("odometry", "initial pose has a non-finite entry");
}

Odometry::~Odometry() = default;

Matrix6d fallbackCovariance(const OdometryConfig& c) {
  Vector6d d;
  const double t2 = c.fallback_sigma_translation * c.fallback_sigma_translation;
  const double r2 = c.fallback_sigma_rotation * c.fallback_sigma_rotation;
  d << t2, t2, t2, r2, r2, r2;
  return d.asDiagonal();
}

namespace {

// A scan after preprocessing: cropped and downsampled keeping property classes (`frame`, what
// enters the map or becomes the next frame's target), and the source that is registered.
struct PreparedScan {
  LabeledCloud frame;
  LabeledCloud coarse;  ///< the registered source when source_voxel_size > voxel_size
  bool separate_source = false;
  double ms = 0.0;
  const LabeledCloud& source() const { return separate_source ? coarse : frame; }
};

PreparedScan prepareScan(const LabeledCloud& scan, const OdometryConfig& config, const ClassTable& classes) {
  PreparedScan out;
  out.separate_source = config.source_voxel_size > config.voxel_size;
  const auto t = Clock::now();
  out.frame = preprocessForTracking(scan, config, classes);
  if (out.separate_source) out.coarse = voxelDownsample(out.frame, propertyVoxels(config.source_voxel_size), classes);
  out.ms = msSince(t);
  return out;
}

// The scan prepared for tracking and, frame to map after the first frame (`map` given), the local
// map's registration target built meanwhile: it does not depend on this scan, and a downsampling
// has a serial pass that leaves the other cores idle. Lazy normals: ICP estimates only those of
// the map points it pairs with.
PreparedScan prepareFrame(const LabeledCloud& scan, const OdometryConfig& config, const ClassTable& classes,
                          LocalMap* map, std::optional<RegistrationTarget>& map_target) {
  PreparedScan prepared;
  const auto preprocess = [&] { prepared = prepareScan(scan, config, classes); };
  if (config.mode == OdometryMode::FrameToMap && map) {
    tbb::parallel_invoke(preprocess, [&] {
      map_target.emplace(map->makeTarget(classes, config.registration, /*lazy_normals=*/true));
    });
  } else {
    preprocess();
  }
  return prepared;
}

RegistrationResult unregistered(const char* reason) {
  RegistrationResult r;
  r.reason = reason;
  return r;
}

}  // namespace

LabeledCloud preprocessForTracking(const LabeledCloud& scan, const OdometryConfig& config, const ClassTable& classes) {
  RangeCropConfig crop;
  crop.min_range = config.min_range;
  crop.max_range = config.max_range;
  return cropAndDownsample(scan, crop, propertyVoxels(config.voxel_size), classes);
}

// Registration in its own space W: frame to map it estimates world ← current, frame to frame
// target-scan ← current (the target is the last non-empty scan, normally the previous one).
struct Odometry::Attempt {
  Eigen::Isometry3d prev_pose;  ///< world ← the previous frame
  Eigen::Isometry3d W;          ///< world ← registration space
  Eigen::Isometry3d guess;      ///< the guessed pose in registration space
  const RegistrationTarget* target = nullptr;
  bool has_prior = false;       ///< wheel odometry, or a verified last increment
};

// What judging left: the estimate the frame keeps (registration space) and whether the next
// guess drops the increment's roll and pitch.
struct Odometry::Judgement {
  Estimate estimate;
  bool levels_velocity = false;
};

// The paper's Fig. 1 for one scan: preprocess, register against the previous scan or the local
// map from the wheel-odometry guess, check the result, then update the map.
const OdometryFrame& Odometry::addFrame(const LabeledCloud& scan,
                                        const std::optional<Eigen::Isometry3d>& wheel_increment,
                                        double stamp, const std::optional<Eigen::Matrix3d>& imu_rotation) {
  const auto t_start = Clock::now();
  OdometryFrame f;
  f.index = frames_.size();
  const std::string where = "odometry frame " + std::to_string(f.index);
  if (wheel_increment && !isFinite(*wheel_increment)) fail(where, "wheel odometry increment is not finite");
  if (imu_rotation && !imu_rotation->allFinite()) fail(where, "IMU rotation is not finite");
  scan.checkConsistent(where);
  if (config_.registration.use_classes) classes_.checkCloud(scan, where);
  f.stamp = stamp >= 0.0 ? stamp : static_cast<double>(f.index);
  f.scan_points = scan.size();

  // 1. prepare: crop and downsample (frame to map, the local map's target is built meanwhile)
  std::optional<RegistrationTarget> map_target;
  const PreparedScan prepared = prepareFrame(scan, config_, classes_, frames_.empty() ? nullptr : &map_, map_target);
  f.source_points = prepared.source().size();
  f.preprocess_ms = prepared.ms;

  if (frames_.empty()) {
    f.pose = initial_pose_;
    f.status = FrameStatus::First;
    impl_->velocity_verified = false;
    if (labelsDecideAxes(config_)) impl_->scan_labels = labelledPointsOf(scan, config_, classes_);
  } else {
    if (labelsDecideAxes(config_)) prepareLabels(scan);
    Attempt a = guess(f, wheel_increment, imu_rotation, map_target);  // 2. guess
    if (a.target && config_.motion_hypotheses.enabled && !wheel_increment) seedFromHypotheses(f, a, prepared.source());
    RegistrationResult r = a.target ? registerClouds(prepared.source(), *a.target, a.guess, classes_, config_.registration)
                                    : unregistered("no previous scan to register against");  // 3. register (eq. 2)
    f.searches += icpSearches(r, config_.registration);
    const Judgement j = judge(f, prepared.source(), a, map_target, r);  // 4. judge: checks, recovery
    place(f, a, j, std::move(r));
  }
  // 5. integrate: the scan enters the local map (or becomes the next frame's target)
  remember(f, prepared.frame);
  if (labelsDecideAxes(config_)) impl_->frame_labels.push_back({f.index, std::move(impl_->scan_labels)});
  f.total_ms = msSince(t_start);
  f.registration_ms = f.total_ms - f.preprocess_ms;
  frames_.push(std::move(f));
  return frames_.back();
}

void Odometry::keepNewestFrames(std::size_t n) {
  frames_.keepNewest(std::max(n, reestimationReach(config_.recovery)));
}

std::optional<Eigen::Matrix3d> verifiedRotation(const OdometryFrame& f) {
  if (f.status != FrameStatus::Tracked) return std::nullopt;
  return f.increment.linear();
}

// The wheel increment, else constant velocity (identity before the first increment); the gyro's
// rotation when there is an IMU.
Odometry::Attempt Odometry::guess(OdometryFrame& f, const std::optional<Eigen::Isometry3d>& wheel_increment,
                                  const std::optional<Eigen::Matrix3d>& imu_rotation,
                                  std::optional<RegistrationTarget>& map_target) const {
  Attempt a;
  a.prev_pose = frames_.back().pose;
  f.wheel_guess = wheel_increment.has_value();
  f.guess = wheel_increment ? *wheel_increment
                            : (impl_->has_velocity ? impl_->velocity : Eigen::Isometry3d::Identity());
  // The gyro measures the turn: it replaces a constant velocity's (which misses every change)
  // and the wheels' where they disagree by more than the gyro's own error over a frame (a kick or
  // a spin the tracks did not report); where they agree the wheels' turn has no bias to learn.
  constexpr double kWheelGyroDisagreement = 2.0 * M_PI / 180.0;
  if (imu_rotation && (!wheel_increment || Eigen::AngleAxisd(wheel_increment->linear().transpose() * *imu_rotation).angle() >
                                               kWheelGyroDisagreement))
    f.guess.linear() = *imu_rotation, f.imu_guess = true;
  const bool to_map = config_.mode == OdometryMode::FrameToMap;
  a.W = to_map ? Eigen::Isometry3d::Identity() : impl_->previous_pose;
  a.guess = a.W.inverse() * a.prev_pose * f.guess;
  a.target = to_map ? &*map_target : impl_->previous.get();
  if (a.target) f.map_points = a.target->size();
  a.has_prior = wheel_increment.has_value() || impl_->velocity_verified;
  return a;
}

// Without wheel odometry, a start that fits the target clearly better than the constant-velocity
// guess replaces it (a sudden turn). Not with the wheels: on the simulated tanks (cylinders, yaw
// alike) the sweep's starts fitted better in wrong basins (map error 0.19 -> 14.8 m,
// docs/registration.md), while the wheels' yaw is a measurement.
void Odometry::seedFromHypotheses(OdometryFrame& f, Attempt& a, const LabeledCloud& source) {
  HypothesisInputs in;
  in.guess = f.guess;
  if (impl_->has_velocity) in.last_increment = impl_->velocity;
  const Eigen::Isometry3d previous = a.W.inverse() * a.prev_pose;
  const HypothesisLimits limits{config_.max_correction_translation, config_.max_correction_rotation,
                                config_.recovery.max_translation, config_.recovery.max_rotation};
  const HypothesisChoice c = impl_->hypotheses.choose(source, *a.target, previous, in, classes_, config_.registration,
                                                      limits, config_.motion_hypotheses);
  f.searches += c.searches;
  if (!c.replaced || !plausibleMotion(c.increment, config_)) return;
  f.guess = c.increment;
  f.guess_hypothesis = c.name;
  a.guess = previous * f.guess;
}

// The checks, recovery when one fails or the answer is suspect, the whole map when several frames
// in a row found nothing (a kidnapped robot): the frame's status and reason, and what it keeps.
Odometry::Judgement Odometry::judge(OdometryFrame& f, const LabeledCloud& source, const Attempt& a,
                                    std::optional<RegistrationTarget>& map_target, RegistrationResult& r) {
  bool relocalised = false;
  std::string failure = checkAndRecover(f, source, a.target, a.W, a.guess, a.has_prior, r, relocalised);
  if (config_.mode == OdometryMode::FrameToMap) map_target.reset();  // its lazy normals read the map, which changes
  if (!failure.empty() && config_.recovery.relocalise && config_.recovery.whole_map && !source.empty() &&
      impl_->fallback_streak + 1 >= static_cast<std::size_t>(config_.recovery.whole_map_after)) {
    if (std::optional<RegistrationResult> g = relocaliseInWholeMap(f, source, a.prev_pose * f.guess)) {
      r = std::move(*g);
      const Matrix6d Ad = adjoint(a.W.inverse());  // world → W space (identity frame to map)
      r.transform = a.W.inverse() * r.transform;
      r.covariance = Ad * r.covariance * Ad.transpose();
      failure.clear();
      relocalised = true;
    }
  }
  Judgement j{{r.transform, r.covariance}};
  if (!failure.empty()) {
    f.status = FrameStatus::Fallback;
    f.reason = f.global.trigger.empty() || failure == f.global.outcome ? failure : failure + "; " + f.global.outcome;
    j.estimate.pose = a.guess;
  } else if (relocalised) {
    f.status = FrameStatus::Relocalised;
    f.reason = f.global.trigger + "; " + f.global.outcome;
  } else if (const std::vector<Vector6d> basis = degenerateBasis(r, config_); !basis.empty()) {
    f.reason = describeDegenerate(basis);
    j.estimate = keepGuessAlong(basis, r, a.guess, config_);
    f.status = FrameStatus::Degenerate;
  } else {
    f.status = FrameStatus::Tracked;
  }
  // A relocalised answer flagged only by the looser kFlagWeakAxisRatio still levels the velocity.
  j.levels_velocity = f.status == FrameStatus::Relocalised &&
                      !(config_.recovery.relocalise_suspect &&
                        weakHorizontalAxis(r, kSuspectWeakAxisRatio));
  if (f.status == FrameStatus::Tracked || f.status == FrameStatus::Relocalised)
    labelledOrFlagged(f, r, j.estimate, config_, source, a.W, a.guess, {impl_->label_note, impl_->label_precise, impl_->label_doubt});
  flagAfterFlagged(f, frames_.back(), j.estimate.pose, a.guess, a.W, config_);
  return j;
}

// The frame's increment, pose and covariance, and the motion model the next guess comes from.
void Odometry::place(OdometryFrame& f, const Attempt& a, const Judgement& j, RegistrationResult r) {
  f.increment = normalized(a.prev_pose.inverse() * a.W * j.estimate.pose);
  // W-frame perturbation → previous-frame perturbation of the increment
  const Matrix6d Ad = adjoint(a.prev_pose.inverse() * a.W);
  f.covariance = f.status == FrameStatus::Fallback ? fallbackCovariance(config_)
                                                   : Matrix6d(Ad * j.estimate.covariance * Ad.transpose());
  f.pose = normalized(a.prev_pose * f.increment);
  f.registration = std::move(r);
  // A relocalised increment also undoes the drift before it, which is not motion: a ground robot's
  // next guess keeps its travel and yaw but not the roll / pitch of that correction (carried on at
  // constant velocity where the floor leaves pitch weak, naraha without odometry drifted 1 deg a
  // frame until the next relocalisation).
  impl_->velocity = j.levels_velocity ? levelled(f.increment) : f.increment;
  impl_->has_velocity = true;
  impl_->velocity_verified = f.status != FrameStatus::Fallback;
  impl_->fallback_streak = f.status == FrameStatus::Fallback ? impl_->fallback_streak + 1 : 0;
  if (f.status == FrameStatus::Tracked || f.status == FrameStatus::Degenerate)
    impl_->typical_rmse = impl_->typical_rmse > 0.0 ? 0.9 * impl_->typical_rmse + 0.1 * f.registration.inlier_rmse
                                                    : f.registration.inlier_rmse;
}

// A guess-free global registration when ICP from the guess failed or is suspect (issue 19).
std::string Odometry::checkAndRecover(OdometryFrame& f, const LabeledCloud& source, const RegistrationTarget* target,
                                      const Eigen::Isometry3d& W, const Eigen::Isometry3d& reg_guess, bool has_prior,
                                      RegistrationResult& r, bool& relocalised) {
  impl_->label_note.clear();
  impl_->label_doubt.clear();
  std::string failure = registrationFailure(r, reg_guess, config_);
  bool only_weak_axis = false;
  std::string trigger = !failure.empty() ? "ICP from the guess failed: " + failure
                                         : suspicion(r, reg_guess, has_prior, impl_->typical_rmse, config_,
                                                     only_weak_axis);
  // Suspect only for a weak axis: the labels may place the frame along it, leaving nothing to recover.
  if (only_weak_axis && target && labelsDecideAxes(config_) &&
      placeAlongWeakAxis(source, *target, r, kSuspectWeakAxisRatio))
    trigger.clear();
  if (config_.recovery.relocalise && !trigger.empty() && target && !source.empty()) {
    f.global.trigger = trigger;
    std::optional<Recovery> recovered = recover(f, source, *target, W, r, failure.empty(), only_weak_axis);
    if (!recovered && failure.empty()) failure = f.global.outcome;  // ambiguous: flagged
    if (recovered && !recovered->from_guess) {
      r = std::move(recovered->registration);
      failure.clear();
      relocalised = true;
    }
  }
  // ICP from the guess kept but weak along an axis (kFlagWeakAxisRatio): the labels decide, or
  // judge() flags the frame.
  if (failure.empty() && !relocalised && impl_->label_note.empty() && target && labelsDecideAxes(config_))
    placeAlongWeakAxis(source, *target, r, kFlagWeakAxisRatio);
  return failure;
}

bool Odometry::placeAlongWeakAxis(const LabeledCloud& source, const RegistrationTarget& target, RegistrationResult& r,
                                  double ratio) {
  const std::optional<Eigen::Vector3d> axis = weakHorizontalAxis(r, ratio);
  if (!axis) return false;
  const LabelPlacement lp = placeAlongAxisByLabels(impl_->labelView(), classes_, r.transform, *axis, config_);
  if (!lp.decided) {
    impl_->label_doubt = lp.why;
    return false;
  }
  if (!applyPlacementIfGeometryAllows(source, target, r, *axis, lp)) {
    impl_->label_doubt = "the labels' position fits the geometry worse";
    return false;
  }
  impl_->label_note = describe(lp);
  impl_->label_precise = lp.precise;
  return true;
}

void Odometry::prepareLabels(const LabeledCloud& scan) {
  impl_->scan_labels = labelledPointsOf(scan, config_, classes_);
  std::vector<std::pair<Eigen::Isometry3d, const LabeledCloud*>> placed;
  const Eigen::Vector3d here = frames_.back().pose.translation();
  const double reach = kRecoveryMapRadius + config_.label_axis.range;
  for (const auto& [index, labels] : impl_->frame_labels) {
    const Eigen::Isometry3d& pose = frames_.pose(index);
    // Not a fallback's guess; a flagged weak-axis frame's pose is ICP's (its labels starve the map
    // otherwise: the frames after the first could never be placed).
    const bool verified = frames_.status(index) != FrameStatus::Fallback;
    if (verified && !labels.empty() && (pose.translation() - here).norm() <= reach) placed.push_back({pose, &labels});
  }
  impl_->label_map = labelMapOf(placed, classes_);
}

void Odometry::remember(OdometryFrame& f, const LabeledCloud& frame) {
  keepKeyframe(f, frame);
  if (f.global.whole_map && f.status == FrameStatus::Relocalised) {
    rebuildLocalMapFromKeyframes(f.pose);
    for (const auto& lost : impl_->lost)  // carried: where they were in between is unknown
      frames_.full(lost.frame).reason += "; left as it was: the robot was found again against the whole map";
    impl_->lost.clear();
  }
  if (config_.mode == OdometryMode::FrameToMap) {
    // A fallback frame's pose is an unverified guess: its points would place a wrong copy of the
    // scene in the map that the next frames then track against (issue 14, naraha seed 7), so its
    // scan waits outside the map (reestimate_lost_frames).
    LabeledCloud scan_world = frame.transformed(f.pose);
    if (config_.recovery.reestimate_lost_frames) {
      if (f.status == FrameStatus::Fallback) {
        impl_->lost.push_back({f.index, frame, impl_->scan_labels});  // waits outside the map until a later frame is verified
        scan_world = LabeledCloud();
        // Lost for long (a corridor nothing can place along): the map must follow the robot, so the
        // oldest waiting scan enters at its guessed pose, as it would have without waiting.
        if (impl_->lost.size() > static_cast<std::size_t>(config_.recovery.lost_frames_max)) {
          scan_world = impl_->lost.front().scan.transformed(frames_.pose(impl_->lost.front().frame));
          impl_->lost.erase(impl_->lost.begin());
        }
      } else if (!impl_->lost.empty()) {
        scan_world.append(reestimateLostFrames(f, scan_world));  // they enter with this frame's integrate()
      }
    }
    map_.integrate(scan_world, f.pose.translation(), classes_);
    f.map_points = map_.size();
  } else if (!frame.empty() || !impl_->previous) {
    impl_->previous = std::make_unique<RegistrationTarget>(frame, classes_, config_.registration);
    impl_->previous_pose = f.pose;
  }
}

Trajectory Odometry::trajectory() const {
  Trajectory t;
  for (std::size_t i = 0; i < frames_.size(); ++i) t.push_back(frames_.stamp(i), frames_.pose(i));
  return t;
}

}  // namespace hazmap
