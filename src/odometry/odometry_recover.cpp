// Recovery of a frame whose tracking ICP failed or is suspect (issue 19): a guess-free global
// registration against the same target, plus ICP from a few other starts around the motion
// prior (no motion: the encoders' travel was a slip; the last increment again).
// Every answer is verified by the tracking ICP and its checks, and must be a plausible motion
// for the platform; the best one is used unless a distinct one fits as well (ambiguous).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "hazmap/registration/global_registration.hpp"
#include "odometry/odometry_checks.hpp"

namespace hazmap {

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

struct Start {
  Eigen::Isometry3d pose;  ///< W space
  std::string name;
};

struct Verified {
  RegistrationResult registration;
  std::string name;
  bool from_guess = false;
};

// The local map (or previous scan) near the sensor: the global registration's target.
LabeledCloud nearbyTarget(const LabeledCloud& cloud, const Eigen::Vector3d& centre, double radius) {
  const Eigen::Vector3f c = centre.cast<float>();
  const float r2 = static_cast<float>(radius * radius);
  std::vector<std::size_t> keep;
  keep.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if ((cloud.points[i] - c).squaredNorm() <= r2) keep.push_back(i);
  return keep.size() == cloud.size() ? cloud : cloud.select(keep);
}

bool distinct(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, const OdometryConfig& c) {
  const Eigen::Isometry3d d = a.inverse() * b;
  return translationNorm(d) > c.relocalise_distinct_translation || rotationAngle(d) > c.relocalise_distinct_rotation;
}

std::string describeAmbiguity(const Verified& a, const Verified& b) {
  const Eigen::Isometry3d d = a.registration.transform.inverse() * b.registration.transform;
  char buf[256];
  std::snprintf(buf, sizeof buf, "ambiguous: %s (fitness %.3f) and %s (fitness %.3f) are %.2f m / %.1f deg apart",
                a.name.c_str(), a.registration.fitness, b.name.c_str(), b.registration.fitness, translationNorm(d),
                rotationAngle(d) * 180.0 / M_PI);
  return buf;
}

}  // namespace

std::optional<Eigen::Isometry3d> Odometry::globalStart(OdometryFrame& f, const LabeledCloud& source,
                                                       const RegistrationTarget& target, const Eigen::Isometry3d& W) {
  GlobalRegistrationConfig gc = config_.global;
  gc.use_classes = gc.use_classes && config_.registration.use_classes;
  // Target points near the sensor; the viewpoint orients the target's normals.
  const Eigen::Vector3d viewpoint = (W.inverse() * frames_.back().pose).translation();
  const GlobalRegistrationTarget prepared = prepareGlobalTarget(
      nearbyTarget(target.cloud(), viewpoint, config_.relocalise_map_radius), classes_, gc, viewpoint.cast<float>());
  const GlobalRegistrationResult g = registerGlobally(source, prepared, classes_, gc);
  f.global.tried = true;
  f.global.status = g.status;
  f.global.score = g.score;
  f.global.second_best_score = g.second_best_score;
  if (g.success && !g.ambiguous) return g.transform;
  f.global.outcome = "global registration: " + (g.reason.empty() ? std::string(toString(g.status)) : g.reason);
  return std::nullopt;
}

std::optional<Odometry::Recovery> Odometry::recover(OdometryFrame& f, const LabeledCloud& source,
                                                    const RegistrationTarget& target, const Eigen::Isometry3d& W,
                                                    const RegistrationResult& from_guess, bool guess_passed) {
  const auto t = Clock::now();
  const Eigen::Isometry3d prev = W.inverse() * frames_.back().pose;  // previous frame in W space
  std::vector<Start> starts;
  if (auto g = globalStart(f, source, target, W)) starts.push_back({*g, "global registration"});
  starts.push_back({prev, "no motion"});
  for (const double deg : {-30.0, 30.0})
    starts.push_back({prev * f.guess * Eigen::AngleAxisd(deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()),
                      "guess turned " + std::to_string(int(deg)) + " deg"});
  if (f.wheel_guess && frames_.size() >= 2) starts.push_back({prev * frames_.back().increment, "constant velocity"});

  std::vector<Verified> verified;
  std::string rejected;
  const auto check = [&](RegistrationResult r, const Eigen::Isometry3d& start, const std::string& name, bool guess) {
    std::string why = registrationFailure(r, start, config_);
    const Eigen::Isometry3d increment = prev.inverse() * r.transform;
    char buf[96];
    if (why.empty() && impl_->typical_rmse > 0.0 && r.inlier_rmse > config_.relocalise_max_rmse_ratio * impl_->typical_rmse) {
      std::snprintf(buf, sizeof buf, "inlier RMSE %.3f m", r.inlier_rmse);
      why = buf;
    } else if (why.empty() && (translationNorm(increment) > config_.relocalise_max_translation ||
                               rotationAngle(increment) > config_.relocalise_max_rotation)) {
      std::snprintf(buf, sizeof buf, "implausible motion %.2f m / %.1f deg", translationNorm(increment),
                    rotationAngle(increment) * 180.0 / M_PI);
      why = buf;
    }
    if (why.empty()) verified.push_back({std::move(r), name, guess});
    else rejected += (rejected.empty() ? "" : "; ") + name + ": " + why;
  };
  if (guess_passed) check(from_guess, W.inverse() * frames_.back().pose * f.guess, "ICP from the guess", true);
  for (const Start& s : starts)
    check(registerClouds(source, target, s.pose, classes_, config_.registration), s.pose, s.name, false);
  f.global.milliseconds = msSince(t);
  if (verified.empty()) {
    f.global.outcome += (f.global.outcome.empty() ? "" : "; ") + std::string("nothing verified (") + rejected + ")";
    return std::nullopt;
  }
  // The best fit wins; ICP from the guess gets relocalise_min_gain ahead (it is what tracking
  // trusts when nothing is wrong). A distinct answer that fits as well makes the frame ambiguous.
  const auto rank = [&](const Verified& v) { return v.registration.fitness + (v.from_guess ? config_.relocalise_min_gain : 0.0); };
  std::size_t best = 0;
  for (std::size_t i = 1; i < verified.size(); ++i)
    if (rank(verified[i]) > rank(verified[best])) best = i;
  for (std::size_t i = 0; i < verified.size(); ++i)
    if (i != best && distinct(verified[i].registration.transform, verified[best].registration.transform, config_) &&
        verified[i].registration.fitness >= verified[best].registration.fitness - config_.relocalise_ambiguity) {
      f.global.outcome = describeAmbiguity(verified[best], verified[i]);
      return std::nullopt;
    }
  f.global.outcome = "used " + verified[best].name;
  return Recovery{std::move(verified[best].registration), verified[best].from_guess};
}

}  // namespace hazmap
