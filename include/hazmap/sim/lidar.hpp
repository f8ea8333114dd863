#pragma once
// The LiDAR model (Velodyne VLP-16 by default) and the per-point property labelling that a
// thermal / near-infrared camera fused to the LiDAR would give. All defaults are part of the
// simulator's specification (issue 3) and must not be tuned to suit a SLAM result.
#include <Eigen/Geometry>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/sim/random.hpp"
#include "hazmap/sim/raycaster.hpp"
#include "hazmap/sim/scene.hpp"

namespace hazmap::sim {

struct LidarConfig {
  int channels = 16;                 ///< laser channels, evenly spaced in elevation
  double min_elevation_deg = -15.0;  ///< lowest channel
  double max_elevation_deg = 15.0;   ///< highest channel (16 channels → 2° steps)
  int columns = 1800;                ///< firings per revolution (0.2° azimuth resolution)
  double min_range = 0.4;            ///< m; closer returns are discarded
  double max_range = 100.0;          ///< m; farther surfaces give no return
  double range_noise_sigma = 0.03;   ///< m, Gaussian noise along the ray
  double dropout_probability = 0.01; ///< chance that a return is lost
  double mount_height = 0.5;         ///< m, sensor origin above the floor

  /// Channel elevations, lowest first (degrees).
  std::vector<double> elevationsDeg() const;
  double azimuthStepDeg() const { return 360.0 / columns; }
  /// Unit ray directions in the sensor frame (x forward, y left, z up), column-major: for each
  /// column (azimuth 0 = +x, counter-clockwise), the channels from lowest to highest.
  std::vector<Eigen::Vector3f> rayDirections() const;
};

struct LabelNoiseConfig {
  /// Share of property points (true class is a property) that lose their class (→ 0).
  double property_dropout = 0.03;
  /// Share of other points that get a wrong property class (uniform over the scene's property
  /// classes, or the table's when the scene has none).
  double false_property = 0.005;
};

/// Optional continuous value per point: the temperature a thermal camera would read.
struct TemperatureConfig {
  bool enabled = false;
  double ambient_c = 20.0;    ///< °C, surfaces outside heat regions
  double hot_c = 60.0;        ///< °C, surfaces inside heat regions
  double noise_sigma_c = 1.5; ///< °C, Gaussian noise per point
};

/// One scan: points in the sensor frame, with their (noisy) class; intensity = |cos| of the
/// incidence angle; `property` = temperature when enabled. `true_classes` (optional output)
/// receives the noise-free class of every returned point.
struct ScanInputs {
  const RayCaster* caster = nullptr;
  const Scene* scene = nullptr;
  const LidarConfig* lidar = nullptr;
  const LabelNoiseConfig* labels = nullptr;
  const TemperatureConfig* temperature = nullptr;
  const std::vector<Eigen::Vector3f>* directions = nullptr;  ///< lidar->rayDirections()
  std::vector<ClassId> false_classes;  ///< classes a false property label is drawn from
  std::vector<ClassId> heat_classes;   ///< classes that are hot for the temperature channel
};

/// `rng` drives ranges, dropouts and labels; `temperature_rng` (required when the temperature
/// channel is enabled) is a separate stream, so switching the channel on changes nothing else.
LabeledCloud simulateScan(const ScanInputs& in, const Eigen::Isometry3d& T_world_sensor, Rng& rng,
                          Rng* temperature_rng = nullptr,
                          std::vector<ClassId>* true_classes = nullptr);

}  // namespace hazmap::sim
