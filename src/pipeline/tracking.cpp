#include "hazmap/pipeline/tracking.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/registration/registration_target.hpp"

namespace hazmap {

struct FrameTracker::State {
  std::unique_ptr<RegistrationTarget> previous;
  Eigen::Isometry3d last_increment = Eigen::Isometry3d::Identity();
  bool first = true;
};

TrackingConfig TrackingConfig::fromYamlString(const std::string& yaml, const std::string& where,
                                              const TrackingConfig& base) {
  TrackingConfig c = base;
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    fail(where, std::string("tracking: invalid YAML: ") + e.msg);
  }
  if (!root.IsMap()) fail(where, "tracking: expected a mapping");
  for (const auto& kv : root) {
    const auto key = kv.first.as<std::string>();
    const YAML::Node& v = kv.second;
    try {
      if (key == "crop") {
        if (v["min_range"]) c.crop.min_range = v["min_range"].as<double>();
        if (v["max_range"]) c.crop.max_range = v["max_range"].as<double>();
      } else if (key == "registration") {
        std::stringstream s;
        s << v;
        c.registration = registrationConfigFromYaml(s.str(), where, c.registration);
      } else if (key == "voxel_size") c.voxel_size = v.as<double>();
      else if (key == "property_share") c.property_share = v.as<double>();
      else if (key == "min_fitness") c.min_fitness = v.as<double>();
      else if (key == "max_rmse") c.max_rmse = v.as<double>();
      else if (key == "max_correction_translation") c.max_correction_translation = v.as<double>();
      else if (key == "max_correction_rotation") c.max_correction_rotation = v.as<double>();
      else if (key == "remap_degenerate") c.remap_degenerate = v.as<bool>();
      else if (key == "min_translation_sigma") c.min_translation_sigma = v.as<double>();
      else if (key == "min_rotation_sigma") c.min_rotation_sigma = v.as<double>();
      else fail(where, "tracking: unknown key '" + key + "'");
    } catch (const YAML::Exception&) {
      fail(where, "tracking: bad value for '" + key + "'");
    }
  }
  c.validate();
  return c;
}

std::string TrackingConfig::toYamlString() const {
  std::ostringstream s;
  s << "crop: {min_range: " << crop.min_range << ", max_range: " << crop.max_range << "}\n"
    << "voxel_size: " << voxel_size << "\nproperty_share: " << property_share
    << "\nmin_fitness: " << min_fitness << "\nmax_rmse: " << max_rmse
    << "\nmax_correction_translation: " << max_correction_translation
    << "\nmax_correction_rotation: " << max_correction_rotation
    << "\nremap_degenerate: " << (remap_degenerate ? "true" : "false")
    << "\nmin_translation_sigma: " << min_translation_sigma
    << "\nmin_rotation_sigma: " << min_rotation_sigma << "\n";
  return s.str();
}

void TrackingConfig::validate() const {
  const auto check = [](bool ok, const std::string& what) {
    if (!ok) fail("tracking config", what);
  };
  check(crop.min_range >= 0 && crop.max_range > crop.min_range, "crop needs 0 <= min_range < max_range");
  check(voxel_size > 0 && std::isfinite(voxel_size), "voxel_size must be > 0");
  check(property_share >= 0 && property_share <= 1, "property_share must be in [0, 1]");
  check(min_fitness >= 0 && min_fitness <= 1, "min_fitness must be in [0, 1]");
  check(max_rmse > 0, "max_rmse must be > 0");
  check(max_correction_translation > 0, "max_correction_translation must be > 0");
  check(max_correction_rotation > 0, "max_correction_rotation must be > 0");
  check(min_translation_sigma > 0 && min_rotation_sigma > 0, "sigma floors must be > 0");
  registration.validate();
}

FrameTracker::FrameTracker(ClassTable classes, TrackingConfig config)
    : classes_(std::move(classes)), config_(std::move(config)), state_(std::make_unique<State>()) {
  config_.validate();
}

FrameTracker::~FrameTracker() = default;

LabeledCloud FrameTracker::preprocess(const LabeledCloud& scan) const {
  VoxelDownsampleConfig voxel;
  voxel.voxel_size = config_.voxel_size;
  voxel.vote = ClassVote::PreferProperty;
  voxel.property_share = config_.property_share;
  return voxelDownsample(cropRange(scan, config_.crop), voxel, classes_);
}

TrackedFrame FrameTracker::track(const LabeledCloud& scan,
                                 const std::optional<Eigen::Isometry3d>& odometry_increment) {
  TrackedFrame out;
  out.preprocessed = preprocess(scan);
  out.points = out.preprocessed.size();
  const Eigen::Isometry3d guess = odometry_increment ? *odometry_increment : state_->last_increment;
  out.T_prev_curr = guess;
  if (state_->first) {
    out.T_prev_curr = Eigen::Isometry3d::Identity();
    out.icp_used = true;
    state_->first = false;
  } else if (!state_->previous || state_->previous->empty() || out.preprocessed.empty()) {
    out.fallback_reason = "empty scan";
  } else {
    // target = previous frame, source = this frame: the result is T_prev_curr.
    const RegistrationResult r =
        registerClouds(out.preprocessed, *state_->previous, guess, classes_, config_.registration);
    out.fitness = r.fitness;
    out.rmse = r.inlier_rmse;
    out.iterations = r.iterations;
    out.covariance = r.covariance;
    out.degenerate_directions = r.degenerate_directions.size();
    Eigen::Isometry3d T = r.transform;
    if (config_.remap_degenerate && !r.degenerate_directions.empty()) {
      // Remove the correction's component along each degenerate direction.
      Vector6d delta = se3Log(T * guess.inverse());
      for (const Vector6d& d : r.degenerate_directions) delta -= d * d.dot(delta);
      T = se3Exp(delta) * guess;
    }
    const Eigen::Isometry3d correction = T * guess.inverse();
    if (!r.converged && r.iterations < config_.registration.max_iterations)
      out.fallback_reason = "registration failed: " + r.reason;
    else if (r.fitness < config_.min_fitness)
      out.fallback_reason = "low fitness " + std::to_string(r.fitness);
    else if (r.inlier_rmse > config_.max_rmse)
      out.fallback_reason = "high rmse " + std::to_string(r.inlier_rmse);
    else if (translationNorm(correction) > config_.max_correction_translation ||
             rotationAngle(correction) > config_.max_correction_rotation)
      out.fallback_reason = "diverged from the guess";
    if (out.fallback_reason.empty()) {
      out.T_prev_curr = normalized(T);
      out.icp_used = true;
    }
  }
  if (!out.icp_used || !state_->previous) out.covariance = Matrix6d::Identity();
  state_->last_increment = out.T_prev_curr;
  state_->previous = std::make_unique<RegistrationTarget>(out.preprocessed, classes_, config_.registration);
  return out;
}

}  // namespace hazmap
