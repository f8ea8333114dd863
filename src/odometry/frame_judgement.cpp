// Judging a tracked frame (issue 19): did ICP from the guess fail, is its answer suspect, along
// which directions does the guess stay, and is the frame flagged. Plain functions of the
// registration's result and the configuration; Odometry::judge calls them in order.
#include "odometry/frame_judgement.hpp"

#include <cmath>
#include <cstdio>

#include "hazmap/preprocess/normals.hpp"
#include "odometry/odometry_checks.hpp"

namespace hazmap {

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

// Why a registration that passed its checks is still suspect (empty when it is not): the triggers
// for trying a global registration as well (issue 19).
std::string suspicion(const RegistrationResult& r, const Eigen::Isometry3d& guess, bool has_prior,
                      double typical_rmse, const OdometryConfig& config, bool& only_weak_axis) {
  only_weak_axis = false;
  if (!config.recovery.relocalise_suspect) return {};
  if (!has_prior) return "no motion prior";
  char buf[160];
  if (fitsWorseThanTracked(r, typical_rmse)) {
    std::snprintf(buf, sizeof buf, "poor fit: inlier RMSE %.3f m above %.1f x that of tracked frames (%.3f m)",
                  r.inlier_rmse, kMaxRmseRatio, typical_rmse);
    return buf;
  }
  if (r.fitness < kSuspectFitness) {
    std::snprintf(buf, sizeof buf, "poor fit: fitness %.3f below the suspect threshold %.3f", r.fitness,
                  kSuspectFitness);
    return buf;
  }
  const Vector6d correction = correctionOf(r, guess);
  const double dt = correction.head<3>().norm(), dr = correction.tail<3>().norm();
  if (dt > kSuspectCorrectionTranslation || dr > kSuspectCorrectionRotation) {
    std::snprintf(buf, sizeof buf, "far from the guess: %.3f m / %.2f deg", dt, dr * 180.0 / M_PI);
    return buf;
  }
  if (const auto axis = weakHorizontalAxis(r, kSuspectWeakAxisRatio)) {
    std::snprintf(buf, sizeof buf, "weakly constrained along [%.2f %.2f %.2f]", (*axis)(0), (*axis)(1), (*axis)(2));
    only_weak_axis = true;
    return buf;
  }
  return {};
}

namespace {

// An orthonormal basis of the registration's degenerate directions.
std::vector<Vector6d> orthonormalBasis(const std::vector<Vector6d>& directions) {
  std::vector<Vector6d> basis;
  for (Vector6d d : directions) {
    for (const auto& b : basis) d -= b.dot(d) * b;
    if (d.norm() > 1e-6) basis.push_back(d.normalized());
  }
  return basis;
}

}  // namespace

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


namespace {

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

}  // namespace

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

// The directions along which the guess is kept: ICP's own (in its space).
std::vector<Vector6d> degenerateBasis(const RegistrationResult& r, const OdometryConfig&) {
  return orthonormalBasis(r.degenerate_directions);
}

// The scan's own surfaces (normals from the scan alone, over a wider neighbourhood than tracking's
// so that neighbouring rings make a plane, lines left out) as a point-to-plane Hessian in the
// world's axes about the sensor (rotation free about the sensor, not the world origin: far from
// the origin a turn would read as travel), and its weak horizontal axis. It does not read the map: in the
// corridor worst day with the gyro, walls integrated a few degrees apart and normals of lone rings
// gave ICP's Hessian an axis that the walls do not have, and 17 frames stood still `tracked`
// while the robot drove 1 m a frame.
std::optional<Eigen::Vector3d> scanWeakHorizontalAxis(const LabeledCloud& source, const Eigen::Isometry3d& pose,
                                                      double ratio) {
  if (source.size() < 3) return std::nullopt;
  NormalConfig nc;
  nc.neighbors = kScanSurfaceNeighbors;
  nc.radius = kScanSurfaceRadius;
  const std::vector<Eigen::Vector3f> normals = estimateNormals(source, nc);
  Matrix6d H = Matrix6d::Zero();
  for (std::size_t i = 0; i < source.size(); ++i) {
    if (normals[i].isZero()) continue;
    const Eigen::Vector3d n = pose.linear() * normals[i].cast<double>();
    const Eigen::Vector3d p = pose.linear() * source.points[i].cast<double>();  // about the sensor
    Vector6d J;
    J << n, p.cross(n);
    H.selfadjointView<Eigen::Lower>().rankUpdate(J);
  }
  H = H.selfadjointView<Eigen::Lower>();
  return weakHorizontalAxis(H, ratio);
}

namespace {

// With relocalise_suspect: along a weakly constrained horizontal axis ICP cannot know the motion
// (a corridor: "no motion" fits as well as the true step), so such a frame is flagged, ICP's
// answer kept, with the fallback covariance along the axis. Weak in ICP's Hessian, or, without
// wheel odometry, in the scan's own surfaces (scanWeakHorizontalAxis): there the guess is the
// constant velocity of frames that may have stood still, and the map's normals can claim what the
// walls cannot. With the wheels the guess along the axis is a measurement (asking the scan alone
// moved corridor seeds 1 and 3 by recoveries, 0.5 → 6.7 m, not adopted): such a frame is flagged
// only where ICP's answer left the wheels along the scan's weak axis (kFlagWheelDisagreement).
void flagWeakAxis(OdometryFrame& f, const RegistrationResult& r, Estimate& estimate, const OdometryConfig& config,
                  const LabeledCloud& source, const Eigen::Isometry3d& W, const Eigen::Isometry3d& guess) {
  if (!config.recovery.relocalise_suspect) return;
  std::optional<Eigen::Vector3d> axis = weakHorizontalAxis(r, kFlagWeakAxisRatio);
  const char* whose = "";
  char wheels[80] = "";
  // With the wheels, only an answer that left them by more than the threshold can be flagged for
  // the scan's own surfaces (its distance along any unit axis is at most this): the scan's normals
  // are not estimated for every frame.
  const bool may_flag = !f.wheel_guess || (estimate.pose.translation() - guess.translation()).norm() > kFlagWheelDisagreement;
  if (!axis && may_flag)
    if (const auto scan_axis = scanWeakHorizontalAxis(source, W * estimate.pose, kScanWeakAxisRatio)) {
      const Eigen::Vector3d in_w = W.linear().transpose() * *scan_axis;  // world → registration space
      const double from_wheels = in_w.dot(estimate.pose.translation() - guess.translation());
      if (!f.wheel_guess || std::abs(from_wheels) > kFlagWheelDisagreement) {
        axis = in_w;
        whose = " in the scan's own surfaces";
        if (f.wheel_guess) std::snprintf(wheels, sizeof wheels, ", %+.2f m from the wheels along it", from_wheels);
      }
    }
  if (!axis) return;
  Vector6d b = Vector6d::Zero();
  b.head<3>() = *axis;
  estimate.covariance += config.fallback_sigma_translation * config.fallback_sigma_translation * b * b.transpose();
  char buf[300];
  std::snprintf(buf, sizeof buf, "weakly constrained%s along [%.2f %.2f %.2f]%s: ICP cannot know the motion along it (flagged)",
                whose, (*axis)(0), (*axis)(1), (*axis)(2), wheels);
  f.reason = f.reason.empty() ? std::string(buf) : f.reason + "; " + buf;
  f.status = FrameStatus::Degenerate;
}

}  // namespace

// A tracked or relocalised frame: placed along its weak axis by its labels (flagged when not to
// the centimetre), or flagged for the weak axis as before.
void labelledOrFlagged(OdometryFrame& f, const RegistrationResult& r, Estimate& estimate, const OdometryConfig& config,
                       const LabeledCloud& source, const Eigen::Isometry3d& W, const Eigen::Isometry3d& guess,
                       const LabelVerdict& labels) {
  if (!labels.note.empty()) {
    f.reason += (f.reason.empty() ? "" : "; ") + labels.note;
    if (!labels.precise) f.status = FrameStatus::Degenerate;
    return;
  }
  flagWeakAxis(f, r, estimate, config, source, W, guess);
  if (f.status == FrameStatus::Degenerate && !labels.doubt.empty()) f.reason += "; " + labels.doubt;
}

// With relocalise_suspect: the previous frame was flagged, so its pose is not known along its
// weakest horizontal axis, and this frame's increment starts there. An answer farther from the
// guess along that axis than kFlagCorrectionAfterFlagged is that pose's error put right (or a
// slip of the encoders): the data cannot tell which, so the increment is not known either
// (corridor worst day, seed 1: frame 35 beside the south heat panel put right frame 34, flagged
// 0.40 m off, and was `tracked` 0.49 m off in its increment). A lost frame (fallback) that is
// re-estimated later is left to reestimateLostFrames, which flags the frame after it when it stays lost.
void flagAfterFlagged(OdometryFrame& f, const OdometryFrame& previous, const Eigen::Isometry3d& answer,
                      const Eigen::Isometry3d& guess, const Eigen::Isometry3d& W, const OdometryConfig& config) {
  if (!config.recovery.relocalise_suspect || !(kFlagCorrectionAfterFlagged > 0.0) || !isFlagged(previous.status)) return;
  if (f.status != FrameStatus::Tracked && f.status != FrameStatus::Relocalised) return;
  const bool to_map = config.mode == OdometryMode::FrameToMap;
  const bool lost_reestimated = previous.status == FrameStatus::Fallback && to_map && config.recovery.reestimate_lost_frames;
  if (lost_reestimated) return;
  Eigen::Vector3d delta = W.linear() * (answer.translation() - guess.translation());  // world
  delta.z() = 0.0;
  double along = delta.norm();
  // Frame to map the previous registration's space is the world's: measure along its weakest axis.
  if (to_map && previous.status == FrameStatus::Degenerate)
    if (const auto axis = weakHorizontalAxis(previous.registration, 1.0)) along = std::abs(axis->dot(delta));
  if (along <= kFlagCorrectionAfterFlagged) return;
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "%.2f m from the guess along the flagged frame %zu's weakest axis: its pose's error or a slip, "
                "the increment is not known (flagged)", along, previous.index);
  f.reason += (f.reason.empty() ? "" : "; ") + std::string(buf);
  f.status = FrameStatus::Degenerate;
}

}  // namespace hazmap
