#include "hazmap/sim/lidar.hpp"

#include <algorithm>
#include <cmath>

namespace hazmap::sim {

std::vector<double> LidarConfig::elevationsDeg() const {
  std::vector<double> e(static_cast<std::size_t>(std::max(channels, 0)));
  for (int k = 0; k < channels; ++k)
    e[k] = channels == 1 ? min_elevation_deg
                         : min_elevation_deg + (max_elevation_deg - min_elevation_deg) * k / (channels - 1);
  return e;
}

std::vector<Eigen::Vector3f> LidarConfig::rayDirections() const {
  const auto elevations = elevationsDeg();
  std::vector<Eigen::Vector3f> dirs;
  dirs.reserve(static_cast<std::size_t>(columns) * elevations.size());
  for (int c = 0; c < columns; ++c) {
    const double az = 2.0 * M_PI * c / columns;
    for (double el_deg : elevations) {
      const double el = el_deg * M_PI / 180.0;
      dirs.emplace_back(static_cast<float>(std::cos(el) * std::cos(az)),
                        static_cast<float>(std::cos(el) * std::sin(az)),
                        static_cast<float>(std::sin(el)));
    }
  }
  return dirs;
}

LabeledCloud simulateScan(const ScanInputs& in, const Eigen::Isometry3d& T_world_sensor, Rng& rng,
                          Rng* temperature_rng, std::vector<ClassId>* true_classes) {
  const auto& dirs_sensor = *in.directions;
  const Eigen::Matrix3f R = T_world_sensor.linear().cast<float>();
  const Eigen::Vector3f origin = T_world_sensor.translation().cast<float>();
  std::vector<Eigen::Vector3f> dirs_world(dirs_sensor.size());
  for (std::size_t i = 0; i < dirs_sensor.size(); ++i) dirs_world[i] = R * dirs_sensor[i];

  std::vector<RayHit> hits;
  in.caster->cast(origin, dirs_world, 0.0f, static_cast<float>(in.lidar->max_range), hits);

  LabeledCloud cloud;
  cloud.enableIntensity();
  const bool temperature = in.temperature && in.temperature->enabled && temperature_rng;
  if (temperature) cloud.enableProperty();
  cloud.reserve(hits.size());
  if (true_classes) {
    true_classes->clear();
    true_classes->reserve(hits.size());
  }
  const double sigma = in.lidar->range_noise_sigma;
  const double dropout = in.lidar->dropout_probability;
  const double min_range = in.lidar->min_range, max_range = in.lidar->max_range;
  for (std::size_t i = 0; i < hits.size(); ++i) {
    const RayHit& h = hits[i];
    // The same draws for every ray, hit or not, in a fixed order: ray k's noise depends only on
    // (seed, frame, k), not on whether some other ray happened to graze an edge.
    const bool dropped = rng.bernoulli(dropout);
    const double noise = rng.normal(sigma);
    const double u_label = rng.uniform();
    const std::uint64_t pick = rng.next();
    const double temperature_noise = temperature ? temperature_rng->normal() : 0.0;
    if (!h.hit() || h.distance < min_range || h.distance > max_range || dropped) continue;
    const double range = std::max(static_cast<double>(h.distance) + noise, 0.0);
    const Eigen::Vector3d surface =
        origin.cast<double>() + static_cast<double>(h.distance) * dirs_world[i].cast<double>();
    const PropertyRegion* region = in.scene->regionAt(surface);
    const ClassId truth = region ? region->class_id : 0;
    ClassId observed = truth;
    if (truth != 0) {
      if (u_label < in.labels->property_dropout) observed = 0;
    } else if (u_label < in.labels->false_property && !in.false_classes.empty()) {
      observed = in.false_classes[pick % in.false_classes.size()];
    }
    const float cos_incidence = std::abs(h.normal.dot(dirs_world[i]));
    float temp = 0.0f;
    if (temperature) {
      const bool hot = std::find(in.heat_classes.begin(), in.heat_classes.end(), truth) !=
                       in.heat_classes.end();
      temp = static_cast<float>((hot ? in.temperature->hot_c + region->temperature_offset_c : in.temperature->ambient_c) +
                                in.temperature->noise_sigma_c * temperature_noise);
    }
    cloud.push_back((range * dirs_sensor[i].cast<double>()).cast<float>(), observed,
                    std::clamp(cos_incidence, 0.0f, 1.0f), 0.0, temp);
    if (true_classes) true_classes->push_back(truth);
  }
  return cloud;
}

}  // namespace hazmap::sim
