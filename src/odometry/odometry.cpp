#include "hazmap/odometry/odometry.hpp"

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
#include "odometry/odometry_checks.hpp"

namespace hazmap {

const char* toString(OdometryMode mode) { return mode == OdometryMode::FrameToFrame ? "frame" : "map"; }

const char* toString(FrameStatus status) {
  switch (status) {
    case FrameStatus::First: return "first";
    case FrameStatus::Tracked: return "tracked";
    case FrameStatus::Degenerate: return "degenerate";
    case FrameStatus::Relocalised: return "relocalised";
    case FrameStatus::Fallback: return "fallback";
  }
  return "unknown";
}

const char* describe(FrameStatus status) {
  switch (status) {
    case FrameStatus::First: return "first: the initial pose";
    case FrameStatus::Tracked: return "tracked: ICP from the guess";
    case FrameStatus::Degenerate: return "tracked: ICP from the guess, the guess kept along degenerate directions";
    case FrameStatus::Relocalised: return "relocalised: global registration (no guess) verified by ICP";
    case FrameStatus::Fallback: return "fallback: nothing verified, the guessed increment used (flagged)";
  }
  return "unknown";
}


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

VoxelDownsampleConfig trackingVoxels(double voxel_size) {
  VoxelDownsampleConfig vd;
  vd.voxel_size = voxel_size;
  vd.vote = ClassVote::PreferProperty;
  return vd;
}

PreparedScan prepareScan(const LabeledCloud& scan, const OdometryConfig& config, const ClassTable& classes) {
  PreparedScan out;
  out.separate_source = config.source_voxel_size > config.voxel_size;
  const auto t = Clock::now();
  out.frame = preprocessForTracking(scan, config, classes);
  if (out.separate_source) out.coarse = voxelDownsample(out.frame, trackingVoxels(config.source_voxel_size), classes);
  out.ms = msSince(t);
  return out;
}

}  // namespace

LabeledCloud preprocessForTracking(const LabeledCloud& scan, const OdometryConfig& config, const ClassTable& classes) {
  RangeCropConfig crop;
  crop.min_range = config.min_range;
  crop.max_range = config.max_range;
  return cropAndDownsample(scan, crop, trackingVoxels(config.voxel_size), classes);
}

// How far ICP moved the sensor from where it started, in the sensor's own frame. Measured as a
// left perturbation in the world frame, a small turn of a sensor far from the world origin read
// as metres of travel (6 deg at 30 m from the origin: 3.2 m), and right answers 6-9 deg from a
// recovery start were refused as "diverged" (naraha worst day, frames 52-55).
Vector6d correctionOf(const RegistrationResult& r, const Eigen::Isometry3d& start) {
  return se3Log(start.inverse() * r.transform);
}

// Stopping at the iteration limit is not a failure: the pose is usually close, and the other
// checks still apply.
std::string registrationFailure(const RegistrationResult& r, const Eigen::Isometry3d& guess,
                                const OdometryConfig& config) {
  const bool hit_limit = !r.converged && r.termination == Termination::MaxIterations;
  if (!r.converged && !hit_limit) return r.reason;
  char buf[160];
  if (r.fitness < config.min_fitness) {
    std::snprintf(buf, sizeof buf, "fitness %.3f below min_fitness %.3f", r.fitness, config.min_fitness);
    return buf;
  }
  const Vector6d correction = correctionOf(r, guess);
  const double dt = correction.head<3>().norm(), dr = correction.tail<3>().norm();
  if (!(dt > config.max_correction_translation || dr > config.max_correction_rotation)) return {};
  std::snprintf(buf, sizeof buf, "diverged: %.3f m / %.2f deg from the guess (limits %.3f m / %.2f deg)", dt,
                dr * 180.0 / M_PI, config.max_correction_translation, config.max_correction_rotation * 180.0 / M_PI);
  return buf;
}

namespace {

// Why a registration that passed its checks is still suspect (empty when it is not): the triggers
// for trying a global registration as well (issue 19).
std::string suspicion(const RegistrationResult& r, const Eigen::Isometry3d& guess, bool has_prior,
                      double typical_rmse, const OdometryConfig& config, bool& only_weak_axis) {
  only_weak_axis = false;
  if (!config.relocalise_suspect) return {};
  if (!has_prior) return "no motion prior";
  char buf[160];
  if (fitsWorseThanTracked(r, typical_rmse, config)) {
    std::snprintf(buf, sizeof buf, "poor fit: inlier RMSE %.3f m above %.1f x that of tracked frames (%.3f m)",
                  r.inlier_rmse, config.relocalise_max_rmse_ratio, typical_rmse);
    return buf;
  }
  if (r.fitness < config.suspect_fitness) {
    std::snprintf(buf, sizeof buf, "poor fit: fitness %.3f below suspect_fitness %.3f", r.fitness,
                  config.suspect_fitness);
    return buf;
  }
  const Vector6d correction = correctionOf(r, guess);
  const double dt = correction.head<3>().norm(), dr = correction.tail<3>().norm();
  if (dt > config.suspect_correction_translation || dr > config.suspect_correction_rotation) {
    std::snprintf(buf, sizeof buf, "far from the guess: %.3f m / %.2f deg", dt, dr * 180.0 / M_PI);
    return buf;
  }
  if (const auto axis = weakHorizontalAxis(r, config.suspect_weak_axis_ratio)) {
    std::snprintf(buf, sizeof buf, "weakly constrained along [%.2f %.2f %.2f]", (*axis)(0), (*axis)(1), (*axis)(2));
    only_weak_axis = true;
    return buf;
  }
  return {};
}

// An orthonormal basis of the registration's degenerate directions.
std::vector<Vector6d> orthonormalBasis(const std::vector<Vector6d>& directions) {
  std::vector<Vector6d> basis;
  for (Vector6d d : directions) {
    for (const auto& b : basis) d -= b.dot(d) * b;
    if (d.norm() > 1e-6) basis.push_back(d.normalized());
  }
  return basis;
}

std::string describeDegenerate(const std::vector<Vector6d>& basis) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%zu degenerate direction(s); guess kept along ", basis.size());
  std::string out = buf;
  for (std::size_t k = 0; k < basis.size(); ++k) {
    char d[96];
    const Vector6d& b = basis[k];
    std::snprintf(d, sizeof d, "%s[%.2f %.2f %.2f %.2f %.2f %.2f]", k ? ", " : "", b(0), b(1), b(2), b(3), b(4), b(5));
    out += d;
  }
  return out;
}

// The motion without its roll and pitch: translation and yaw kept.
Eigen::Isometry3d levelled(const Eigen::Isometry3d& T) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.translation() = T.translation();
  out.linear() = Eigen::AngleAxisd(yawOf(T), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return out;
}

struct Estimate {
  Eigen::Isometry3d pose;  ///< in registration space
  Matrix6d covariance;
};

// Removes delta's components along the orthonormal `basis`; returns the projector onto the rest.
Matrix6d projectOut(const std::vector<Vector6d>& basis, Vector6d& delta) {
  Matrix6d P = Matrix6d::Identity();
  for (const auto& b : basis) {
    delta -= b.dot(delta) * b;
    P -= b * b.transpose();
  }
  return P;
}

// Along each degenerate direction the frame claims only the fallback covariance.
void addFallbackAlong(const std::vector<Vector6d>& basis, const OdometryConfig& config, Matrix6d& covariance) {
  const Matrix6d fb = fallbackCovariance(config);
  for (const auto& b : basis) covariance += (b.transpose() * fb * b)(0, 0) * b * b.transpose();
}

// ICP's answer where it is constrained, the guess along the degenerate directions `basis`, with
// the fallback covariance there.
Estimate keepGuessAlong(const std::vector<Vector6d>& basis, const RegistrationResult& r,
                        const Eigen::Isometry3d& guess, const OdometryConfig& config) {
  Vector6d delta = se3Log(r.transform * guess.inverse());
  const Matrix6d P = projectOut(basis, delta);
  Estimate e{normalized(se3Exp(delta) * guess), r.covariance};
  e.covariance = P * e.covariance * P.transpose();  // (assigned as the tested results were computed)
  addFallbackAlong(basis, config, e.covariance);
  return e;
}

// The directions along which the guess is kept: ICP's own (in its space), none unless
// keep_guess_along_degenerate.
std::vector<Vector6d> degenerateBasis(const RegistrationResult& r, const OdometryConfig& config) {
  if (!config.keep_guess_along_degenerate) return {};
  return orthonormalBasis(r.degenerate_directions);
}

// With relocalise_suspect: along a weakly constrained horizontal axis ICP cannot know the motion
// (a corridor: "no motion" fits as well as the true step), so such a frame is flagged, ICP's
// answer kept, with the fallback covariance along the axis.
void flagWeakAxis(OdometryFrame& f, const RegistrationResult& r, Estimate& estimate, const OdometryConfig& config) {
  if (!config.relocalise_suspect || !config.flag_weak_axis) return;
  const std::optional<Eigen::Vector3d> axis = weakHorizontalAxis(r, config.flag_weak_axis_ratio);
  if (!axis) return;
  Vector6d b = Vector6d::Zero();
  b.head<3>() = *axis;
  estimate.covariance += config.fallback_sigma_translation * config.fallback_sigma_translation * b * b.transpose();
  char buf[160];
  std::snprintf(buf, sizeof buf, "weakly constrained along [%.2f %.2f %.2f]: ICP cannot know the motion along it (flagged)",
                (*axis)(0), (*axis)(1), (*axis)(2));
  f.reason = f.reason.empty() ? std::string(buf) : f.reason + "; " + buf;
  f.status = FrameStatus::Degenerate;
}

// A tracked or relocalised frame: placed along its weak axis by its labels (flagged when not to
// the centimetre), or flagged for the weak axis as before.
void labelledOrFlagged(OdometryFrame& f, const RegistrationResult& r, Estimate& estimate, const OdometryConfig& config,
                       const std::string& label_note, bool label_precise, const std::string& label_doubt) {
  if (!label_note.empty()) {
    f.reason += (f.reason.empty() ? "" : "; ") + label_note;
    if (!label_precise) f.status = FrameStatus::Degenerate;
    return;
  }
  flagWeakAxis(f, r, estimate, config);
  if (f.status == FrameStatus::Degenerate && !label_doubt.empty()) f.reason += "; " + label_doubt;
}

// With relocalise_suspect: the previous frame was flagged, so its pose is not known along its
// weakest horizontal axis, and this frame's increment starts there. An answer farther from the
// guess along that axis than flag_correction_after_flagged is that pose's error put right (or a
// slip of the encoders): the data cannot tell which, so the increment is not known either
// (corridor worst day, seed 1: frame 35 beside the south heat panel put right frame 34, flagged
// 0.40 m off, and was `tracked` 0.49 m off in its increment). A lost frame (fallback) that is
// re-estimated later is left to reestimateLostFrames, which flags the frame after it when it stays lost.
void flagAfterFlagged(OdometryFrame& f, const OdometryFrame& previous, const Eigen::Isometry3d& answer,
                      const Eigen::Isometry3d& guess, const Eigen::Isometry3d& W, const OdometryConfig& config) {
  if (!config.relocalise_suspect || !(config.flag_correction_after_flagged > 0.0) || !isFlagged(previous.status)) return;
  if (f.status != FrameStatus::Tracked && f.status != FrameStatus::Relocalised) return;
  const bool to_map = config.mode == OdometryMode::FrameToMap;
  const bool lost_reestimated = previous.status == FrameStatus::Fallback && to_map && config.reestimate_lost_frames;
  if (lost_reestimated) return;
  Eigen::Vector3d delta = W.linear() * (answer.translation() - guess.translation());  // world
  delta.z() = 0.0;
  double along = delta.norm();
  // Frame to map the previous registration's space is the world's: measure along its weakest axis.
  if (to_map && previous.status == FrameStatus::Degenerate)
    if (const auto axis = weakHorizontalAxis(previous.registration, 1.0)) along = std::abs(axis->dot(delta));
  if (along <= config.flag_correction_after_flagged) return;
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "%.2f m from the guess along the flagged frame %zu's weakest axis: its pose's error or a slip, "
                "the increment is not known (flagged)", along, previous.index);
  f.reason += (f.reason.empty() ? "" : "; ") + std::string(buf);
  f.status = FrameStatus::Degenerate;
}

}  // namespace

// The paper's Fig. 1 for one scan: preprocess, register against the previous scan or the local
// map from the wheel-odometry guess, check the result, then update the map.
const OdometryFrame& Odometry::addFrame(const LabeledCloud& scan,
                                        const std::optional<Eigen::Isometry3d>& wheel_increment,
                                        double stamp) {
  const auto t_start = Clock::now();
  OdometryFrame f;
  f.index = frames_.size();
  const std::string where = "odometry frame " + std::to_string(f.index);
  if (wheel_increment && !isFinite(*wheel_increment)) fail(where, "wheel odometry increment is not finite");
  scan.checkConsistent(where);
  if (config_.registration.use_classes) classes_.checkCloud(scan, where);
  f.stamp = stamp >= 0.0 ? stamp : static_cast<double>(f.index);
  f.scan_points = scan.size();

  // 1. preprocessing. Frame to map, the local map's registration target is built meanwhile: it
  //    does not depend on this scan, and a downsampling has a serial pass that leaves the other
  //    cores idle.
  PreparedScan prepared;
  std::optional<RegistrationTarget> map_target;
  const auto preprocess = [&] { prepared = prepareScan(scan, config_, classes_); };
  if (config_.mode == OdometryMode::FrameToMap && !frames_.empty()) {
    // Lazy normals: ICP estimates only those of the map points it pairs with.
    tbb::parallel_invoke(preprocess, [&] {
      map_target.emplace(map_.makeTarget(classes_, config_.registration, /*lazy_normals=*/true));
    });
  } else {
    preprocess();
  }
  f.source_points = prepared.source().size();
  f.preprocess_ms = prepared.ms;

  // 2.–4. registration, failure detection, the pose
  if (frames_.empty()) {
    f.pose = initial_pose_;
    f.status = FrameStatus::First;
    impl_->velocity_verified = false;
  } else {
    if (labelsDecideAxes(config_)) prepareLabels(scan);
    track(f, prepared.source(), map_target, wheel_increment);
  }
  if (labelsDecideAxes(config_) && frames_.empty()) impl_->scan_labels = labelledPointsOf(scan, config_, classes_);
  // 5. the map / the previous scan
  remember(f, prepared.frame);
  if (labelsDecideAxes(config_)) impl_->frame_labels.push_back({f.index, std::move(impl_->scan_labels)});
  f.total_ms = msSince(t_start);
  f.registration_ms = f.total_ms - f.preprocess_ms;
  frames_.push_back(std::move(f));
  return frames_.back();
}

void Odometry::track(OdometryFrame& f, const LabeledCloud& source, std::optional<RegistrationTarget>& map_target,
                     const std::optional<Eigen::Isometry3d>& wheel_increment) {
  const Eigen::Isometry3d prev_pose = frames_.back().pose;
  f.wheel_guess = wheel_increment.has_value();
  f.guess = wheel_increment ? *wheel_increment
                            : (impl_->has_velocity ? impl_->velocity : Eigen::Isometry3d::Identity());
  // Registration in its own space W: FrameToMap estimates world ← current, FrameToFrame
  // target-scan ← current (the target is the last non-empty scan, normally the previous one).
  const bool to_map = config_.mode == OdometryMode::FrameToMap;
  const Eigen::Isometry3d W = to_map ? Eigen::Isometry3d::Identity() : impl_->previous_pose;
  const Eigen::Isometry3d reg_guess = W.inverse() * prev_pose * f.guess;
  const RegistrationTarget* target = to_map ? &*map_target : impl_->previous.get();
  RegistrationResult r;
  if (target) {
    f.map_points = target->size();
    r = registerClouds(source, *target, reg_guess, classes_, config_.registration);
  } else {
    r.reason = "no previous scan to register against";
  }

  const bool has_prior = wheel_increment.has_value() || impl_->velocity_verified;
  bool relocalised = false;
  std::string failure = checkAndRecover(f, source, target, W, reg_guess, has_prior, r, relocalised);
  if (to_map) map_target.reset();  // its lazy normals read the map, which changes below
  // A kidnapped robot: several frames in a row nothing verified; try the whole map.
  if (!failure.empty() && config_.relocalise && config_.whole_map_relocalise && !source.empty() &&
      impl_->fallback_streak + 1 >= static_cast<std::size_t>(config_.whole_map_after)) {
    if (std::optional<RegistrationResult> g = relocaliseInWholeMap(f, source, prev_pose * f.guess)) {
      r = std::move(*g);
      const Matrix6d Ad = adjoint(W.inverse());  // world → W space (identity frame to map)
      r.transform = W.inverse() * r.transform;
      r.covariance = Ad * r.covariance * Ad.transpose();
      failure.clear();
      relocalised = true;
    }
  }

  Estimate estimate{r.transform, r.covariance};
  if (!failure.empty()) {
    f.status = FrameStatus::Fallback;
    f.reason = f.global.trigger.empty() || failure == f.global.outcome ? failure : failure + "; " + f.global.outcome;
    estimate.pose = reg_guess;
  } else if (relocalised) {
    f.status = FrameStatus::Relocalised;
    f.reason = f.global.trigger + "; " + f.global.outcome;
  } else if (const std::vector<Vector6d> basis = degenerateBasis(r, config_); !basis.empty()) {
    f.reason = describeDegenerate(basis);
    estimate = keepGuessAlong(basis, r, reg_guess, config_);
    f.status = FrameStatus::Degenerate;
  } else {
    f.status = FrameStatus::Tracked;
  }
  // A relocalised answer flagged only by the looser flag_weak_axis_ratio still levels the velocity.
  const bool level_velocity = f.status == FrameStatus::Relocalised &&
                              !(config_.relocalise_suspect && config_.flag_weak_axis &&
                                weakHorizontalAxis(r, config_.suspect_weak_axis_ratio));
  if (f.status == FrameStatus::Tracked || f.status == FrameStatus::Relocalised)
    labelledOrFlagged(f, r, estimate, config_, impl_->label_note, impl_->label_precise, impl_->label_doubt);
  flagAfterFlagged(f, frames_.back(), estimate.pose, reg_guess, W, config_);
  f.increment = normalized(prev_pose.inverse() * W * estimate.pose);
  // W-frame perturbation → previous-frame perturbation of the increment
  const Matrix6d Ad = adjoint(prev_pose.inverse() * W);
  f.covariance = f.status == FrameStatus::Fallback ? fallbackCovariance(config_)
                                                   : Matrix6d(Ad * estimate.covariance * Ad.transpose());
  f.pose = normalized(prev_pose * f.increment);
  f.registration = std::move(r);
  // A relocalised increment also undoes the drift before it, which is not motion: a ground robot's
  // next guess keeps its travel and yaw but not the roll / pitch of that correction (carried on at
  // constant velocity where the floor leaves pitch weak, naraha without odometry drifted 1 deg a
  // frame until the next relocalisation).
  impl_->velocity = level_velocity ? levelled(f.increment) : f.increment;
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
      placeAlongWeakAxis(source, *target, r, config_.suspect_weak_axis_ratio))
    trigger.clear();
  if (config_.relocalise && !trigger.empty() && target && !source.empty()) {
    f.global.trigger = trigger;
    std::optional<Recovery> recovered = recover(f, source, *target, W, r, failure.empty(), only_weak_axis);
    if (!recovered && failure.empty()) failure = f.global.outcome;  // ambiguous: flagged
    if (recovered && !recovered->from_guess) {
      r = std::move(recovered->registration);
      failure.clear();
      relocalised = true;
    }
  }
  // ICP from the guess kept but weak along an axis (flag_weak_axis_ratio): the labels decide, or
  // track() flags the frame.
  if (failure.empty() && !relocalised && impl_->label_note.empty() && target && labelsDecideAxes(config_) &&
      config_.flag_weak_axis)
    placeAlongWeakAxis(source, *target, r, config_.flag_weak_axis_ratio);
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
  if (!applyPlacementIfGeometryAllows(source, target, r, *axis, lp, config_)) {
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
  const double reach = config_.relocalise_map_radius + config_.label_axis_range;
  for (const auto& [index, labels] : impl_->frame_labels) {
    const OdometryFrame& k = frames_[index];
    // Not a fallback's guess; a flagged weak-axis frame's pose is ICP's (its labels starve the map
    // otherwise: the frames after the first could never be placed).
    const bool verified = k.status != FrameStatus::Fallback;
    if (verified && !labels.empty() && (k.pose.translation() - here).norm() <= reach) placed.push_back({k.pose, &labels});
  }
  impl_->label_map = labelMapOf(placed, config_, classes_);
}

void Odometry::remember(OdometryFrame& f, const LabeledCloud& frame) {
  keepKeyframe(f, frame);
  if (f.global.whole_map && f.status == FrameStatus::Relocalised) {
    rebuildLocalMapFromKeyframes(f.pose);
    for (const auto& lost : impl_->lost)  // carried: where they were in between is unknown
      frames_[lost.frame].reason += "; left as it was: the robot was found again against the whole map";
    impl_->lost.clear();
  }
  if (config_.mode == OdometryMode::FrameToMap) {
    // A fallback frame's pose is an unverified guess: its points would place a wrong copy of the
    // scene in the map that the next frames then track against (issue 14, naraha seed 7), so its
    // scan waits outside the map (reestimate_lost_frames).
    LabeledCloud scan_world = frame.transformed(f.pose);
    if (config_.reestimate_lost_frames) {
      if (f.status == FrameStatus::Fallback) {
        impl_->lost.push_back({f.index, frame, impl_->scan_labels});  // waits outside the map until a later frame is verified
        scan_world = LabeledCloud();
        // Lost for long (a corridor nothing can place along): the map must follow the robot, so the
        // oldest waiting scan enters at its guessed pose, as it would have without waiting.
        if (impl_->lost.size() > static_cast<std::size_t>(config_.lost_frames_max)) {
          scan_world = impl_->lost.front().scan.transformed(frames_[impl_->lost.front().frame].pose);
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
  for (const auto& f : frames_) t.push_back(f.stamp, f.pose);
  return t;
}

}  // namespace hazmap
