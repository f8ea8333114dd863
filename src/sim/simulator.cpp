#include "hazmap/sim/simulator.hpp"

#include <algorithm>
#include <cmath>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"

namespace hazmap::sim {

Simulator::Simulator(const SimulatorConfig& config, Scene scene, ClassTable table,
                     std::optional<Eigen::Isometry3d> truth_origin)
    : config_(config), truth_origin_(std::move(truth_origin)), scene_(std::move(scene)), table_(std::move(table)) {
  config_.validate();
  scene_.validate(table_, "scene " + scene_.name);
  if (scene_.mesh.triangle_classes.size() != scene_.mesh.triangles.size()) scene_.labelTriangles();
  init();
}

void Simulator::init() {
  samples_ = config_.closed_route
                 ? sampleRoute(closedLoop(scene_.route, "closed_route (scene " + scene_.name + ")"), config_.robot, true)
                 : sampleRoute(scene_.route, config_.robot);
  const CrawlerUpsetConfig& u = config_.upsets;
  if (u.drop_probability > 0.0 || u.yaw_kick_probability > 0.0)
    kicks_ = applyCrawlerUpsets(samples_, u, config_.seed);
  if (config_.max_frames > 0 && samples_.size() > config_.max_frames) samples_.resize(config_.max_frames);
  if (!kicks_.empty()) kicks_.resize(samples_.size());
  world_.clear();
  truth_.clear();
  for (const auto& s : samples_)
    world_.push_back(sensorPose(s, scene_.route.floor_z, config_.sensor.mount_height));
  // KITTI convention: poses relative to the first scan (what an odometry / SLAM run produces).
  const Eigen::Isometry3d first_inv = (truth_origin_ ? *truth_origin_ : world_.front()).inverse();
  for (const auto& T : world_) truth_.push_back(normalized(first_inv * T));
  odometry_ = accumulateOdometry(truth_, config_.odometry, config_.seed, &slips_, kicks_.empty() ? nullptr : &kicks_);

  caster_ = std::make_unique<RayCaster>(scene_.mesh);
  directions_ = config_.sensor.rayDirections();
  inputs_.caster = caster_.get();
  inputs_.scene = &scene_;
  inputs_.lidar = &config_.sensor;
  inputs_.labels = &config_.labels;
  inputs_.temperature = &config_.temperature;
  inputs_.directions = &directions_;
  // False property labels are drawn from the property classes the scene uses (a thermal camera
  // mistakes something for heat, an NIR camera for water), else from the table's.
  for (ClassId id : scene_.regionClasses())
    if (table_.isProperty(id)) inputs_.false_classes.push_back(id);
  if (inputs_.false_classes.empty())
    for (ClassId id : table_.ids())
      if (table_.isProperty(id)) inputs_.false_classes.push_back(id);
  for (ClassId id : table_.ids())
    if (table_.at(id).kind == PropertyKind::Heat) inputs_.heat_classes.push_back(id);
}

LabeledCloud Simulator::scan(std::size_t i, std::vector<ClassId>* true_classes) const {
  if (i >= truth_.size())
    fail("simulator", "frame " + std::to_string(i) + " out of range (" + std::to_string(truth_.size()) + " frames)");
  Rng rng(config_.seed, RngStream::Scan, i);
  Rng temperature_rng(config_.seed, RngStream::Temperature, i);
  return simulateScan(inputs_, world_[i], rng, &temperature_rng, true_classes);
}

GravitySample Simulator::gravity(std::size_t i) const {
  if (i >= truth_.size())
    fail("simulator", "frame " + std::to_string(i) + " out of range (" + std::to_string(truth_.size()) + " frames)");
  return simulateGravity(world_[i], samples_[i].time, config_.imu, config_.seed, i);
}

OdometryDrift odometryDrift(const PoseList& truth, const PoseList& odometry,
                            const std::vector<bool>& slips) {
  OdometryDrift d;
  const std::size_t n = std::min(truth.size(), odometry.size());
  if (n == 0) return d;
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double e = (odometry[i].translation() - truth[i].translation()).norm();
    sum += e;
    d.max_position_error = std::max(d.max_position_error, e);
    if (i > 0) {
      const Eigen::Isometry3d rel_true = truth[i - 1].inverse() * truth[i];
      const Eigen::Isometry3d rel_odo = odometry[i - 1].inverse() * odometry[i];
      const Eigen::Isometry3d err = rel_true.inverse() * rel_odo;
      d.max_frame_translation_error = std::max(d.max_frame_translation_error, translationNorm(err));
      d.max_frame_rotation_error_deg =
          std::max(d.max_frame_rotation_error_deg, rotationAngle(err) * 180.0 / M_PI);
    }
  }
  d.mean_position_error = sum / static_cast<double>(n);
  d.final_position_error = (odometry[n - 1].translation() - truth[n - 1].translation()).norm();
  d.slips = static_cast<std::size_t>(std::count(slips.begin(), slips.end(), true));
  return d;
}

}  // namespace hazmap::sim
