// SimulatorConfig and its parts: their field tables (core/config_fields.hpp) and the YAML
// entry points derived from them.
#include <yaml-cpp/yaml.h>

#include <algorithm>

#include "hazmap/core/config_fields.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/sim/simulator.hpp"

namespace hazmap::sim {

const ConfigFields<LidarConfig>& configFields(ConfigTag<LidarConfig>) {
  using C = LidarConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("The simulated spinning LiDAR (a VLP-16 by default).")
          .integer("channels", &C::channels, closed(1, 1024), "Laser channels, evenly spaced in elevation")
          .number("min_elevation_deg", &C::min_elevation_deg, closed(-90, 90), "° of the lowest channel")
          .number("max_elevation_deg", &C::max_elevation_deg, closed(-90, 90), "° of the highest channel")
          .integer("columns", &C::columns, closed(1, 100000), "Firings per revolution")
          .number("min_range", &C::min_range, nonNegative(), "m; closer returns are discarded")
          .number("max_range", &C::max_range, positive(), "m; farther surfaces give no return")
          .number("range_noise_sigma", &C::range_noise_sigma, nonNegative(), "m, Gaussian noise along the ray")
          .number("dropout_probability", &C::dropout_probability, closed(0, 1), "Chance that a return is lost")
          .number("mount_height", &C::mount_height, anyNumber(), "m, sensor origin above the floor")
          .rule("max_elevation_deg", [](const C& c) { return c.min_elevation_deg <= c.max_elevation_deg; },
                "must be >= min_elevation_deg")
          .rule("min_range", [](const C& c) { return c.min_range < c.max_range; }, "must be < sensor.max_range");
  return fields;
}

const ConfigFields<LabelNoiseConfig>& configFields(ConfigTag<LabelNoiseConfig>) {
  using C = LabelNoiseConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Label noise of the property camera.")
          .number("property_dropout", &C::property_dropout, closed(0, 1),
                  "Share of property points that lose their class")
          .number("false_property", &C::false_property, closed(0, 1),
                  "Share of other points that get a wrong property class");
  return fields;
}

const ConfigFields<TemperatureConfig>& configFields(ConfigTag<TemperatureConfig>) {
  using C = TemperatureConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Optional temperature channel (what a thermal camera would read).")
          .flag("enabled", &C::enabled, "Write the per-point temperature channel")
          .number("ambient_c", &C::ambient_c, anyNumber(), "°C outside heat regions")
          .number("hot_c", &C::hot_c, anyNumber(), "°C inside heat regions")
          .number("noise_sigma_c", &C::noise_sigma_c, nonNegative(), "°C, Gaussian noise per point");
  return fields;
}

const ConfigFields<RobotConfig>& configFields(ConfigTag<RobotConfig>) {
  using C = RobotConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("The crawler's motion and scan triggers.")
          .number("max_speed", &C::max_speed, positive(), "m/s along legs and arcs")
          .number("turn_rate_deg", &C::turn_rate_deg, positive(), "°/s when turning on the spot")
          .number("frame_distance", &C::frame_distance, positive(), "m of travel between scans")
          .number("frame_turn_deg", &C::frame_turn_deg, positive(), "° of turn between scans");
  return fields;
}

const ConfigFields<OdometryNoiseConfig>& configFields(ConfigTag<OdometryNoiseConfig>) {
  using C = OdometryNoiseConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Encoder odometry errors of the crawler.")
          .number("forward_scale_sigma", &C::forward_scale_sigma, nonNegative(), "Forward distance × (1 + N(0, σ))")
          .number("lateral_sigma", &C::lateral_sigma, nonNegative(), "m, lateral N(0, σ) per frame")
          .number("yaw_sigma_deg", &C::yaw_sigma_deg, nonNegative(), "°, yaw N(0, σ) per frame")
          .number("skid_fraction", &C::skid_fraction, nonNegative(), "Yaw skid N(0, fraction × |turn|)")
          .number("slip_probability", &C::slip_probability, closed(0, 1),
                  "Per frame: the encoders report extra forward travel that did not happen")
          .number("slip_min", &C::slip_min, nonNegative(), "m, smallest slip")
          .number("slip_max", &C::slip_max, nonNegative(), "m, largest slip")
          .rule("slip_min", [](const C& c) { return c.slip_min <= c.slip_max; }, "must be <= odometry.slip_max");
  return fields;
}

const ConfigFields<SimCameraConfig>& configFields(ConfigTag<SimCameraConfig>) {
  using C = SimCameraConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("One simulated property camera; `name` picks its channel and the defaults of the others.")
          .text("name", &C::name, "thermal (temperature) | nir (nir_reflectance) | gamma (dose_rate), or any folder name with `kind`")
          .text("kind", &C::kind, "thermal | nir | gamma when the name is not one of them (e.g. several thermal cameras)")
          .writeIf([](const C& c) { return !c.kind.empty(); })
          .integer("width", &C::width, closed(2, 16384), "pixels")
          .integer("height", &C::height, closed(2, 16384), "pixels")
          .number("hfov_deg", &C::hfov_deg, openClosed(0, 170), "° horizontal field of view")
          .number("k1", &C::k1, anyNumber(), "plumb_bob radial distortion")
          .number("k2", &C::k2, anyNumber(), "plumb_bob radial distortion")
          .custom({"position", "list", "m, camera centre in the LiDAR frame", "[x, y, z]", {}, {}},
                  [](C& c, const YAML::Node& n, const ConfigPlace& p) {
                    if (!n.IsSequence() || n.size() != 3) p.fail("must be a list of 3 numbers [x, y, z]");
                    for (int k = 0; k < 3; ++k) c.position[k] = config_detail::readNumber(n[k], p);
                  },
                  [](const C& c) { return nlohmann::json::array({c.position.x(), c.position.y(), c.position.z()}); },
                  [](const C& c, const ConfigPlace& p) {
                    if (!c.position.allFinite()) p.fail("must be finite");
                  })
          .number("pitch_deg", &C::pitch_deg, closed(-90, 90), "° down from looking forward along LiDAR x")
          .number("yaw_deg", &C::yaw_deg, closed(-360, 360), "° turned left about LiDAR z (180 = looking back)")
          .writeIf([](const C& c) { return c.yaw_deg != 0.0; })
          .number("background", &C::background, anyNumber(), "value outside regions of the camera's kind")
          .number("region_value", &C::region_value, anyNumber(), "value inside regions of the camera's kind")
          .number("noise_sigma", &C::noise_sigma, nonNegative(), "per-pixel Gaussian noise (thermal: NETD)")
          .flag("blur", &C::blur, "3×3 binomial blur (about one pixel)");
  return fields;
}

const ConfigFields<RigPlacement>& configFields(ConfigTag<RigPlacement>) {
  using C = RigPlacement;
  static const ConfigFields<C> fields =
      ConfigFields<C>("One place of a camera rig: each listed camera is mounted there as well.")
          .text("name", &C::name, "suffix of the cameras placed here (<kind>_<name>): letters, digits, - and _")
          .number("yaw_deg", &C::yaw_deg, closed(-360, 360), "° turned left about LiDAR z (180 = looking back)")
          .number("hfov_deg", &C::hfov_deg, closedOpen(0, 170), "° horizontal field of view; 0 = the camera's own");
  return fields;
}

const ConfigFields<CameraSimConfig>& configFields(ConfigTag<CameraSimConfig>) {
  using C = CameraSimConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Property cameras rendered per frame (hazmap simulate --cameras), docs/properties.md.")
          .custom({"list", "list",
                   "Cameras in order: a name (thermal | nir | gamma) or a mapping with `name` and any of the camera "
                   "fields (kind, width, height, hfov_deg, k1, k2, position, pitch_deg, yaw_deg, background, region_value, "
                   "noise_sigma, blur)",
                   "[name | {name: ..., ...}]", {},
                   // Documented with the thermal camera's defaults (nir and gamma have their own).
                   fieldsOf<SimCameraConfig>().describe(SimCameraConfig::forName("thermal"))},
                  [](C& c, const YAML::Node& n, const ConfigPlace& p) {
                    if (!n.IsSequence()) p.fail("must be a list of camera names or mappings");
                    c.cameras.clear();
                    for (std::size_t k = 0; k < n.size(); ++k) {
                      const ConfigPlace at = p.child(std::to_string(k));
                      const YAML::Node& item = n[k];
                      if (!item.IsMap() && !item.IsScalar()) at.fail("must be a camera name or a mapping");
                      const YAML::Node name_node = item.IsMap() ? item["name"] : item;
                      if (!name_node) at.fail("needs a name (thermal, nir or gamma)");
                      const bool has_kind = item.IsMap() && item["kind"];
                      const std::string key = has_kind ? "kind" : "name";
                      const std::string kind = config_detail::readString(has_kind ? item["kind"] : name_node, at.child(key));
                      try {
                        c.cameras.push_back(SimCameraConfig::forName(kind));
                      } catch (const Error&) {
                        at.child(key).fail("must be thermal, nir or gamma, got '" + kind + "'");
                      }
                      if (item.IsMap()) fieldsOf<SimCameraConfig>().read(c.cameras.back(), item, at);
                    }
                  },
                  [](const C& c) {
                    nlohmann::json j = nlohmann::json::array();
                    for (const auto& cam : c.cameras) j.push_back(fieldsOf<SimCameraConfig>().write(cam));
                    return j;
                  },
                  [](const C& c, const ConfigPlace& p) {
                    for (std::size_t k = 0; k < c.cameras.size(); ++k)
                      fieldsOf<SimCameraConfig>().check(c.cameras[k], p.child(std::to_string(k)));
                  })
          .custom({"rig", "list",
                   "Camera rig: ring4 (four 90° cameras at 0/90/180/270°), front-rear, or a list of placements "
                   "{name, yaw_deg, hfov_deg}; every camera of `list` is placed at each (<kind>_<name>)",
                   "[]", {}, fieldsOf<RigPlacement>().describe(RigPlacement{})},
                  [](C& c, const YAML::Node& n, const ConfigPlace& p) {
                    if (n.IsScalar()) {
                      const std::string name = config_detail::readString(n, p);
                      try {
                        c.rig = CameraSimConfig::rigPreset(name);
                      } catch (const Error&) {
                        p.fail("must be ring4, front-rear or a list of placements, got '" + name + "'");
                      }
                      return;
                    }
                    if (!n.IsSequence()) p.fail("must be a preset name or a list of placements");
                    c.rig.clear();
                    for (std::size_t k = 0; k < n.size(); ++k) {
                      const ConfigPlace at = p.child(std::to_string(k));
                      if (!n[k].IsMap() || !n[k]["name"]) at.fail("must be a mapping with a name");
                      c.rig.emplace_back();
                      fieldsOf<RigPlacement>().read(c.rig.back(), n[k], at);
                    }
                  },
                  [](const C& c) {
                    nlohmann::json j = nlohmann::json::array();
                    for (const auto& r : c.rig) j.push_back(fieldsOf<RigPlacement>().write(r));
                    return j;
                  },
                  [](const C& c, const ConfigPlace& p) {
                    for (std::size_t k = 0; k < c.rig.size(); ++k)
                      fieldsOf<RigPlacement>().check(c.rig[k], p.child(std::to_string(k)));
                  })
          .writeIf([](const C& c) { return !c.rig.empty(); })
          .number("calibration_error_deg", &C::calibration_error_deg, closed(0, 45),
                  "° rotation error (random axis) of the written T_camera_lidar")
          .number("calibration_error_m", &C::calibration_error_m, closed(0, 1),
                  "m translation error (random direction) of the written T_camera_lidar")
          .number("time_offset", &C::time_offset, anyNumber(), "s, error of the written time_offset");
  return fields;
}
const ConfigFields<CrawlerUpsetConfig>& configFields(ConfigTag<CrawlerUpsetConfig>) {
  using C = CrawlerUpsetConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("The crawler's bad days: true motion the route did not plan and the encoders did not see "
                      "(off by default; preset worst-day).")
          .number("yaw_kick_probability", &C::yaw_kick_probability, closed(0, 1),
                  "Per frame: the crawler spins on debris, unseen by the encoders")
          .number("yaw_kick_min_deg", &C::yaw_kick_min_deg, closed(0, 180), "°, smallest kick (either way)")
          .number("yaw_kick_max_deg", &C::yaw_kick_max_deg, closed(0, 180), "°, largest kick")
          .number("drop_probability", &C::drop_probability, closedOpen(0, 1),
                  "Per frame: the scan is lost (never two in a row), so the next increment spans two triggers")
          .rule("yaw_kick_min_deg", [](const C& c) { return c.yaw_kick_min_deg <= c.yaw_kick_max_deg; },
                "must be <= upsets.yaw_kick_max_deg");
  return fields;
}

const ConfigFields<ImuConfig>& configFields(ConfigTag<ImuConfig>) {
  using C = ImuConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("The crawler's IMU as an AHRS: gravity's direction per scan (gravity.txt), which fixes roll "
                      "and pitch (docs/formats.md).")
          .flag("enabled", &C::enabled, "Write gravity.txt (false: a sequence without IMU)")
          .number("gravity_sigma_deg", &C::gravity_sigma_deg, openClosed(0, 45),
                  "° per axis, noise of the gravity direction (an industrial AHRS's roll/pitch: 0.1–0.3°)")
          // The raw stream's keys appear in simulation.yaml only when it is written (as before otherwise).
          .number("rate_hz", &C::rate_hz, closed(0, 2000), "Hz, imu.txt's gyro + accelerometer samples (0: no imu.txt; 200 a MEMS IMU's usual)")
          .writeIf([](const C& c) { return c.rate_hz > 0; })
          .number("gyro_noise_density", &C::gyro_noise_density, closed(0, 10), "°/s/√Hz, gyro white noise (Bosch BMI088 datasheet: 0.014)")
          .writeIf([](const C& c) { return c.rate_hz > 0; })
          .number("accel_noise_density", &C::accel_noise_density, closed(0, 1e5), "µg/√Hz, accelerometer white noise (BMI088 datasheet: 175)")
          .writeIf([](const C& c) { return c.rate_hz > 0; })
          .number("gyro_bias_sigma", &C::gyro_bias_sigma, closed(0, 10), "°/s, the gyro's turn-on bias after a calibration at rest (the BMI088's raw zero-rate offset: ±1)")
          .writeIf([](const C& c) { return c.rate_hz > 0; })
          .number("gyro_bias_walk", &C::gyro_bias_walk, closed(0, 1), "rad/s²/√Hz, gyro bias random walk (Kalibr's EuRoC ADIS16448: 1.9393e-5)")
          .writeIf([](const C& c) { return c.rate_hz > 0; })
          .number("accel_bias_walk", &C::accel_bias_walk, closed(0, 1), "m/s³/√Hz, accelerometer bias random walk (Kalibr's EuRoC ADIS16448: 3e-3)")
          .writeIf([](const C& c) { return c.rate_hz > 0; });
  return fields;
}

namespace {
// The crawler's worst day (issue 19): the paper's slips made large, spins on debris, lost scans.
void applyWorstDay(SimulatorConfig& c) {
  c.odometry.slip_probability = 0.1;
  c.odometry.slip_min = 0.5;
  c.odometry.slip_max = 2.0;
  c.upsets.yaw_kick_probability = 0.1;
  c.upsets.yaw_kick_min_deg = 10.0;
  c.upsets.yaw_kick_max_deg = 45.0;
  c.upsets.drop_probability = 0.1;
}
}  // namespace

const ConfigFields<SimulatorConfig>& configFields(ConfigTag<SimulatorConfig>) {
  using C = SimulatorConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("hazmap simulate: the paper's experiment (scene, sensor, robot, noise).")
          .preset("preset", &C::preset, {{"none", nullptr}, {"worst-day", applyWorstDay}},
                  "Applied first, other keys override it. worst-day: track slips of 0.5–2 m and yaw kicks of "
                  "10–45° on 10 % of frames each, 10 % of scans lost")
          .text("scenario", &C::scenario, "Built-in scene: naraha, corridor or tanks (unless scene is set)")
          .writeIf([](const C& c) { return c.scene_file.empty(); })
          .text("scene", &C::scene_file, "User scene mesh (.ply); needs regions")
          .writeIf([](const C& c) { return !c.scene_file.empty(); })
          .text("regions", &C::regions_file, "User regions and route (.yaml)")
          .writeIf([](const C& c) { return !c.scene_file.empty(); })
          .text("class_table", &C::class_table, "default, semantic-kitti or a YAML path")
          .integer("seed", &C::seed, nonNegative(), "Random seed (same seed, same bytes)")
          .integer("frames", &C::max_frames, nonNegative(), "0 = the whole route")
          .flag("closed_route", &C::closed_route,
                "Drive only the route's closed loop, back to the start heading at its end: a capture replayed with "
                "`hazmap replay --loop` goes round without a jump")
          .writeIf([](const C& c) { return c.closed_route; })  // simulation.yaml as before without it
          .number("reference_voxel", &C::reference_voxel, positive(), "m, voxel size of reference_map.ply")
          .section("sensor", &C::sensor, "")
          .section("labels", &C::labels, "")
          .section("temperature", &C::temperature, "")
          .section("robot", &C::robot, "")
          .section("odometry", &C::odometry, "")
          .section("cameras", &C::cameras, "")
          .writeIf([](const C& c) { return !c.cameras.empty(); })  // simulation.yaml as before without cameras
          .section("upsets", &C::upsets, "")
          .flag("wheel_odometry", &C::wheel_odometry, "Write odometry.txt (false: a run without wheel odometry)")
          .section("imu", &C::imu, "")
          // Written by `hazmap simulate` into simulation.yaml for information; not settings.
          .ignore("stats")
          .ignore("world_from_first_frame");
  return fields;
}

SimulatorConfig SimulatorConfig::withPreset(const std::string& name, SimulatorConfig base, const std::string& where) {
  YAML::Node node(YAML::NodeType::Map);
  node["preset"] = name;
  fieldsOf<SimulatorConfig>().read(base, node, ConfigPlace{where, ""});
  return base;
}

SimulatorConfig SimulatorConfig::fromYamlFile(const std::filesystem::path& path,
                                              const SimulatorConfig& base) {
  return fromYamlString(readTextFile(path), path.string(), base);
}

SimulatorConfig SimulatorConfig::fromYamlFile(const std::filesystem::path& path) {
  return fromYamlFile(path, SimulatorConfig{});
}

SimulatorConfig SimulatorConfig::fromYamlString(const std::string& yaml, const std::string& where) {
  return fromYamlString(yaml, where, SimulatorConfig{});
}

// Read without validation: the CLI applies its flags first, then validates the result.
SimulatorConfig SimulatorConfig::fromYamlString(const std::string& yaml, const std::string& where,
                                                const SimulatorConfig& base) {
  SimulatorConfig c = base;
  fieldsOf<SimulatorConfig>().read(c, parseConfigYaml(yaml, where), ConfigPlace{where, ""});
  return c;
}

void SimulatorConfig::validate(const std::string& where) const {
  if (scene_file.empty()) {
    const auto names = builtinSceneNames();
    if (std::find(names.begin(), names.end(), scenario) == names.end())
      fail(where, "unknown scenario '" + scenario + "' (known: naraha, corridor, tanks)");
    if (!regions_file.empty()) fail(where, "regions given without a scene mesh (--scene)");
  } else if (regions_file.empty()) {
    fail(where, "a scene mesh (--scene) needs a regions file (--regions) with the route");
  }
  fieldsOf<SimulatorConfig>().check(*this, ConfigPlace{where, ""});
  cameras.validate(where);
}

std::string SimulatorConfig::toYamlString() const { return configToYaml(*this); }

std::string SimulatorConfig::sensorYaml() const {
  YAML::Emitter e;
  e.SetDoublePrecision(15);  // 0.2, not 0.20000000000000001
  e << YAML::BeginMap;
  e << YAML::Key << "model" << YAML::Value << (sensor.channels == 16 ? "VLP-16 (simulated)" : "simulated spinning LiDAR");
  e << YAML::Key << "channels" << YAML::Value << sensor.channels;
  e << YAML::Key << "elevations_deg" << YAML::Value << YAML::Flow << sensor.elevationsDeg();
  e << YAML::Key << "columns" << YAML::Value << sensor.columns;
  e << YAML::Key << "azimuth_resolution_deg" << YAML::Value << sensor.azimuthStepDeg();
  e << YAML::Key << "min_range" << YAML::Value << sensor.min_range;
  e << YAML::Key << "max_range" << YAML::Value << sensor.max_range;
  e << YAML::Key << "range_noise_sigma" << YAML::Value << sensor.range_noise_sigma;
  e << YAML::Key << "dropout_probability" << YAML::Value << sensor.dropout_probability;
  e << YAML::Key << "mount_height" << YAML::Value << sensor.mount_height;
  e << YAML::Key << "frame" << YAML::Value << "x forward, y left, z up; poses are T_world_sensor";
  e << YAML::EndMap;
  return std::string(e.c_str()) + "\n";
}

}  // namespace hazmap::sim
