// Lost frames made good (issue 19, reestimate_lost_frames): a fallback frame's pose is an
// unverified guess — after a 40 deg kick nobody recovered it is 40 deg wrong — so its scan waits
// outside the local map, and the next frames track against the map without it. Once a frame is
// verified again, the waiting frames are re-registered against the recovered map (which now holds
// the verified frame's scan too), each from its pose interpolated between the last frame before
// the gap and the verified one. A verified answer replaces the frame's pose; otherwise the
// interpolated pose is kept, flagged. Either way the increments on both sides follow, so one lost
// frame no longer turns the rest of the route.
#include <cstdio>
#include <string>

#include "hazmap/registration/registration_target.hpp"
#include "odometry/odometry_checks.hpp"

namespace hazmap {

namespace {

// The pose a fraction s of the way from a to b (constant velocity over the gap).
Eigen::Isometry3d interpolate(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double s) {
  return normalized(a * se3Exp(s * se3Log(a.inverse() * b)));
}

}  // namespace

// With relocalise_suspect: the geometry's doubt along the answer's weakest horizontal axis (weak,
// or another position fitting as well) is settled by the labels or refuses the answer (a corridor
// frame was re-estimated 1 m along the axis without this). Placed, `correction` loses its part
// along the axis (the labels moved it there, not a slide). Returns why refused (empty = usable).
std::string Odometry::placeLostFrameAlongAxis(const LabeledCloud& scan, const LabeledCloud& labels,
                                              const RegistrationTarget& target, RegistrationResult& r,
                                              Vector6d& correction, std::string& note, bool& precise) {
  std::string doubt;
  const bool weak = weakHorizontalAxis(r, kFlagWeakAxisRatio).has_value();
  if (!weak) {
    const double fit = surfaceFit(scan, target, r.transform, kSurfaceInlierDistance);
    doubt = ambiguousAlongWeakestAxis(scan, target, classes_, config_, seedConfigOf(config_), r, fit,
                                      "ICP from the interpolated pose");
  }
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  if (!placeByLabels({&labels, &impl_->label_map}, scan, target, classes_, config_, r, doubt, note, precise, &axis))
    return doubt.empty() ? std::string("weakly constrained along an axis") : doubt;
  if (weak && note.empty()) return "weakly constrained along an axis";
  if (note.empty() && labelsDecideAxes(config_))
    if (std::string contradiction = labelsContradict({&labels, &impl_->label_map}, scan, target, classes_, config_, r);
        !contradiction.empty())
      return contradiction;
  if (!note.empty()) {
    // The axis in the sensor frame (correctionOf measures there): the labels' move is not a slide.
    const Eigen::Vector3d a = (r.transform.linear().transpose() * axis).normalized();
    correction.head<3>() -= a.dot(correction.head<3>()) * a;
  }
  return {};
}

LabeledCloud Odometry::reestimateLostFrames(OdometryFrame& f, const LabeledCloud& f_world) {
  std::vector<Impl::LostFrame> lost = std::move(impl_->lost);
  impl_->lost.clear();
  LabeledCloud entering;
  if (lost.empty() || lost.front().frame == 0) return entering;
  // The recovered map: the local map and the verified frame's scan (a one-off target).
  LabeledCloud map_cloud = map_.cloud();
  map_cloud.append(f_world);
  const RegistrationTarget target(std::move(map_cloud), classes_, config_.registration);

  const std::size_t before = lost.front().frame - 1;  // the last frame before the gap
  const auto span = static_cast<double>(f.index - before);
  for (const Impl::LostFrame& l : lost) {
    OdometryFrame& lf = frames_.full(l.frame);
    const Eigen::Isometry3d& prev = frames_.pose(l.frame - 1);
    // From the (re-estimated) previous frame towards the verified one, at constant velocity.
    const double s = 1.0 / (span - static_cast<double>(l.frame - 1 - before));
    const Eigen::Isometry3d guess = interpolate(prev, f.pose, s);
    RegistrationResult r = registerClouds(l.scan, target, guess, classes_, config_.registration);
    std::string why = registrationFailure(r, guess, config_);
    if (why.empty() && !onlyVerticalDegeneracy(r.degenerate_directions)) why = "degenerate";
    Vector6d correction = correctionOf(r, guess);
    std::string label_note;
    bool label_precise = true;
    if (why.empty() && config_.recovery.relocalise_suspect)
      why = placeLostFrameAlongAxis(l.scan, l.labels, target, r, correction, label_note, label_precise);
    else if (why.empty() && weakHorizontalAxis(r, kSuspectWeakAxisRatio))
      why = "weakly constrained along an axis";
    if (why.empty() && fitsWorseThanTracked(r, impl_->typical_rmse))
      why = "inlier RMSE above that of tracked frames";
    // Interpolated translation is close for a ground robot (a kick turns it, a lost scan is a
    // longer step at the same pace); an answer farther from it slid somewhere (a corridor, 1 m
    // along its axis: 13 of 99 frames silently wrong when such answers were used).
    if (why.empty() && correction.head<3>().norm() > kSuspectCorrectionTranslation)
      why = "far from the interpolated pose";
    if (why.empty() && (!plausibleMotion(prev.inverse() * r.transform, config_) || !plausibleMotion(r.transform.inverse() * f.pose, config_)))
      why = "implausible motion";
    char buf[200];
    // Its increment starts from the previous frame's pose: after a frame left interpolated it is
    // no better than that guess, so the frame stays flagged though its own pose is re-registered
    // (used as relocalised, a corridor's such frames were 12-18 deg off in their increments).
    // Placed by labels, but not to the centimetre: the labels' pose, still flagged.
    const bool after_unverified = frames_.status(l.frame - 1) == FrameStatus::Fallback || !label_precise;
    if (why.empty()) {
      lf.pose = normalized(r.transform);
      if (!after_unverified) lf.status = FrameStatus::Relocalised;
      lf.registration = std::move(r);
      const Matrix6d Ad = adjoint(prev.inverse());
      lf.covariance = Ad * lf.registration.covariance * Ad.transpose();
      std::snprintf(buf, sizeof buf, "; re-estimated once frame %zu was verified: ICP against the recovered map%s%s%s",
                    f.index, label_note.empty() ? "" : ", ", label_note.c_str(),
                    after_unverified ? " (flagged: the frame before it is interpolated)" : "");
      entering.append(l.scan.transformed(lf.pose));
    } else {
      lf.pose = guess;  // flagged, its scan stays out of the map
      std::snprintf(buf, sizeof buf, "; pose interpolated between frames %zu and %zu once %zu was verified (re-registration: %s)",
                    before, f.index, f.index, why.c_str());
    }
    lf.reason += buf;
    lf.increment = normalized(prev.inverse() * lf.pose);
    if (lf.status == FrameStatus::Fallback) lf.covariance = fallbackCovariance(config_);
  }
  // The verified frame's increment now starts from the re-estimated last lost frame.
  f.increment = normalized(frames_.pose(lost.back().frame).inverse() * f.pose);
  if (frames_.status(lost.back().frame) == FrameStatus::Fallback) {  // an increment from a guessed pose
    f.covariance = fallbackCovariance(config_);
    f.reason += f.reason.empty() ? "" : "; ";
    f.reason += "increment from an interpolated pose (loose covariance)";
    // Its pose may be right, its increment is not known: flagged (with relocalise_suspect, whose
    // worst-day runs count such frames; corridor: 0.5 m off yet tracked).
    if (config_.recovery.relocalise_suspect && (f.status == FrameStatus::Tracked || f.status == FrameStatus::Relocalised))
      f.status = FrameStatus::Degenerate;
  }
  impl_->velocity = f.increment;  // the motion again, no longer the jump back from a wrong pose
  return entering;
}

}  // namespace hazmap
