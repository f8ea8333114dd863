#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/sim/simulator.hpp"

namespace hazmap::sim {

namespace {

// A table of "section.key" → setter, so parsing, unknown-key detection and error messages come
// from one place.
using Setter = std::function<void(SimulatorConfig&, const YAML::Node&, const std::string& where,
                                  const std::string& key)>;

template <typename T>
T as(const YAML::Node& n, const std::string& where, const std::string& key) {
  try {
    return n.as<T>();
  } catch (const YAML::Exception&) {
    fail(where, "bad value for '" + key + "'");
  }
}

template <typename T, typename Member>
Setter set(Member member) {
  return [member](SimulatorConfig& c, const YAML::Node& n, const std::string& where,
                  const std::string& key) { std::invoke(member, c) = as<T>(n, where, key); };
}

const std::map<std::string, std::map<std::string, Setter>>& setters() {
  using C = SimulatorConfig;
  static const std::map<std::string, std::map<std::string, Setter>> table = {
      {"",
       {{"scenario", set<std::string>([](C& c) -> auto& { return c.scenario; })},
        {"scene", set<std::string>([](C& c) -> auto& { return c.scene_file; })},
        {"regions", set<std::string>([](C& c) -> auto& { return c.regions_file; })},
        {"class_table", set<std::string>([](C& c) -> auto& { return c.class_table; })},
        {"seed", set<std::uint64_t>([](C& c) -> auto& { return c.seed; })},
        {"frames", set<std::size_t>([](C& c) -> auto& { return c.max_frames; })},
        {"reference_voxel", set<double>([](C& c) -> auto& { return c.reference_voxel; })}}},
      {"sensor",
       {{"channels", set<int>([](C& c) -> auto& { return c.sensor.channels; })},
        {"min_elevation_deg", set<double>([](C& c) -> auto& { return c.sensor.min_elevation_deg; })},
        {"max_elevation_deg", set<double>([](C& c) -> auto& { return c.sensor.max_elevation_deg; })},
        {"columns", set<int>([](C& c) -> auto& { return c.sensor.columns; })},
        {"min_range", set<double>([](C& c) -> auto& { return c.sensor.min_range; })},
        {"max_range", set<double>([](C& c) -> auto& { return c.sensor.max_range; })},
        {"range_noise_sigma", set<double>([](C& c) -> auto& { return c.sensor.range_noise_sigma; })},
        {"dropout_probability", set<double>([](C& c) -> auto& { return c.sensor.dropout_probability; })},
        {"mount_height", set<double>([](C& c) -> auto& { return c.sensor.mount_height; })}}},
      {"labels",
       {{"property_dropout", set<double>([](C& c) -> auto& { return c.labels.property_dropout; })},
        {"false_property", set<double>([](C& c) -> auto& { return c.labels.false_property; })}}},
      {"temperature",
       {{"enabled", set<bool>([](C& c) -> auto& { return c.temperature.enabled; })},
        {"ambient_c", set<double>([](C& c) -> auto& { return c.temperature.ambient_c; })},
        {"hot_c", set<double>([](C& c) -> auto& { return c.temperature.hot_c; })},
        {"noise_sigma_c", set<double>([](C& c) -> auto& { return c.temperature.noise_sigma_c; })}}},
      {"robot",
       {{"max_speed", set<double>([](C& c) -> auto& { return c.robot.max_speed; })},
        {"turn_rate_deg", set<double>([](C& c) -> auto& { return c.robot.turn_rate_deg; })},
        {"frame_distance", set<double>([](C& c) -> auto& { return c.robot.frame_distance; })},
        {"frame_turn_deg", set<double>([](C& c) -> auto& { return c.robot.frame_turn_deg; })}}},
      {"odometry",
       {{"forward_scale_sigma", set<double>([](C& c) -> auto& { return c.odometry.forward_scale_sigma; })},
        {"lateral_sigma", set<double>([](C& c) -> auto& { return c.odometry.lateral_sigma; })},
        {"yaw_sigma_deg", set<double>([](C& c) -> auto& { return c.odometry.yaw_sigma_deg; })},
        {"skid_fraction", set<double>([](C& c) -> auto& { return c.odometry.skid_fraction; })},
        {"slip_probability", set<double>([](C& c) -> auto& { return c.odometry.slip_probability; })},
        {"slip_min", set<double>([](C& c) -> auto& { return c.odometry.slip_min; })},
        {"slip_max", set<double>([](C& c) -> auto& { return c.odometry.slip_max; })}}},
  };
  return table;
}

void requireFinite(double v, const std::string& where, const std::string& key) {
  if (!std::isfinite(v)) fail(where, key + " must be a finite number");
}
void requireNonNegative(double v, const std::string& where, const std::string& key) {
  requireFinite(v, where, key);
  if (v < 0.0) fail(where, key + " must be >= 0 (got " + std::to_string(v) + ")");
}
void requirePositive(double v, const std::string& where, const std::string& key) {
  requireFinite(v, where, key);
  if (!(v > 0.0)) fail(where, key + " must be > 0 (got " + std::to_string(v) + ")");
}
void requireProbability(double v, const std::string& where, const std::string& key) {
  requireFinite(v, where, key);
  if (v < 0.0 || v > 1.0) fail(where, key + " must be in [0, 1] (got " + std::to_string(v) + ")");
}

}  // namespace

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

SimulatorConfig SimulatorConfig::fromYamlString(const std::string& yaml, const std::string& where,
                                                const SimulatorConfig& base) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    fail(where, std::string("invalid YAML: ") + e.msg + " at line " + std::to_string(e.mark.line + 1));
  }
  SimulatorConfig c = base;
  if (root.IsNull()) return c;
  if (!root.IsMap()) fail(where, "simulator config must be a YAML mapping");
  const auto& table = setters();
  const auto& top = table.at("");
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>("");
    // Written by `hazmap simulate` into simulation.yaml for information; not settings.
    if (key == "stats" || key == "world_from_first_frame") continue;
    if (auto it = top.find(key); it != top.end()) {
      it->second(c, kv.second, where, key);
      continue;
    }
    auto section = table.find(key);
    if (key.empty() || section == table.end()) fail(where, "unknown key '" + key + "'");
    if (!kv.second.IsMap()) fail(where, "'" + key + "' must be a mapping");
    for (const auto& inner : kv.second) {
      const std::string name = inner.first.as<std::string>("");
      auto it = section->second.find(name);
      if (it == section->second.end()) fail(where, "unknown key '" + key + "." + name + "'");
      it->second(c, inner.second, where, key + "." + name);
    }
  }
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
  if (sensor.channels < 1 || sensor.channels > 1024) fail(where, "sensor.channels must be in 1..1024");
  if (sensor.columns < 1 || sensor.columns > 100000) fail(where, "sensor.columns must be in 1..100000");
  requireFinite(sensor.min_elevation_deg, where, "sensor.min_elevation_deg");
  requireFinite(sensor.max_elevation_deg, where, "sensor.max_elevation_deg");
  if (sensor.min_elevation_deg > sensor.max_elevation_deg || sensor.min_elevation_deg < -90.0 ||
      sensor.max_elevation_deg > 90.0)
    fail(where, "sensor elevations must satisfy -90 <= min_elevation_deg <= max_elevation_deg <= 90");
  requireNonNegative(sensor.min_range, where, "sensor.min_range");
  requirePositive(sensor.max_range, where, "sensor.max_range");
  if (sensor.min_range >= sensor.max_range) fail(where, "sensor.min_range must be < sensor.max_range");
  requireNonNegative(sensor.range_noise_sigma, where, "sensor.range_noise_sigma");
  requireProbability(sensor.dropout_probability, where, "sensor.dropout_probability");
  requireFinite(sensor.mount_height, where, "sensor.mount_height");
  requireProbability(labels.property_dropout, where, "labels.property_dropout");
  requireProbability(labels.false_property, where, "labels.false_property");
  requireFinite(temperature.ambient_c, where, "temperature.ambient_c");
  requireFinite(temperature.hot_c, where, "temperature.hot_c");
  requireNonNegative(temperature.noise_sigma_c, where, "temperature.noise_sigma_c");
  requirePositive(robot.max_speed, where, "robot.max_speed");
  requirePositive(robot.turn_rate_deg, where, "robot.turn_rate_deg");
  requirePositive(robot.frame_distance, where, "robot.frame_distance");
  requirePositive(robot.frame_turn_deg, where, "robot.frame_turn_deg");
  requireNonNegative(odometry.forward_scale_sigma, where, "odometry.forward_scale_sigma");
  requireNonNegative(odometry.lateral_sigma, where, "odometry.lateral_sigma");
  requireNonNegative(odometry.yaw_sigma_deg, where, "odometry.yaw_sigma_deg");
  requireNonNegative(odometry.skid_fraction, where, "odometry.skid_fraction");
  requireProbability(odometry.slip_probability, where, "odometry.slip_probability");
  requireNonNegative(odometry.slip_min, where, "odometry.slip_min");
  requireNonNegative(odometry.slip_max, where, "odometry.slip_max");
  if (odometry.slip_min > odometry.slip_max) fail(where, "odometry.slip_min must be <= odometry.slip_max");
  requirePositive(reference_voxel, where, "reference_voxel");
  cameras.validate(where);
}

std::string SimulatorConfig::toYamlString() const {
  YAML::Emitter e;
  e.SetDoublePrecision(15);  // 0.2, not 0.20000000000000001
  e << YAML::BeginMap;
  if (scene_file.empty()) {
    e << YAML::Key << "scenario" << YAML::Value << scenario;
  } else {
    e << YAML::Key << "scene" << YAML::Value << scene_file;
    e << YAML::Key << "regions" << YAML::Value << regions_file;
  }
  e << YAML::Key << "class_table" << YAML::Value << class_table;
  e << YAML::Key << "seed" << YAML::Value << seed;
  e << YAML::Key << "frames" << YAML::Value << max_frames;
  e << YAML::Key << "reference_voxel" << YAML::Value << reference_voxel;
  auto section = [&e](const char* name, std::initializer_list<std::pair<const char*, double>> kv) {
    e << YAML::Key << name << YAML::Value << YAML::BeginMap;
    for (const auto& [k, v] : kv) e << YAML::Key << k << YAML::Value << v;
    e << YAML::EndMap;
  };
  section("sensor", {{"channels", sensor.channels},
                     {"min_elevation_deg", sensor.min_elevation_deg},
                     {"max_elevation_deg", sensor.max_elevation_deg},
                     {"columns", sensor.columns},
                     {"min_range", sensor.min_range},
                     {"max_range", sensor.max_range},
                     {"range_noise_sigma", sensor.range_noise_sigma},
                     {"dropout_probability", sensor.dropout_probability},
                     {"mount_height", sensor.mount_height}});
  section("labels", {{"property_dropout", labels.property_dropout},
                     {"false_property", labels.false_property}});
  e << YAML::Key << "temperature" << YAML::Value << YAML::BeginMap;
  e << YAML::Key << "enabled" << YAML::Value << temperature.enabled;
  e << YAML::Key << "ambient_c" << YAML::Value << temperature.ambient_c;
  e << YAML::Key << "hot_c" << YAML::Value << temperature.hot_c;
  e << YAML::Key << "noise_sigma_c" << YAML::Value << temperature.noise_sigma_c;
  e << YAML::EndMap;
  section("robot", {{"max_speed", robot.max_speed},
                    {"turn_rate_deg", robot.turn_rate_deg},
                    {"frame_distance", robot.frame_distance},
                    {"frame_turn_deg", robot.frame_turn_deg}});
  section("odometry", {{"forward_scale_sigma", odometry.forward_scale_sigma},
                       {"lateral_sigma", odometry.lateral_sigma},
                       {"yaw_sigma_deg", odometry.yaw_sigma_deg},
                       {"skid_fraction", odometry.skid_fraction},
                       {"slip_probability", odometry.slip_probability},
                       {"slip_min", odometry.slip_min},
                       {"slip_max", odometry.slip_max}});
  e << YAML::EndMap;
  return std::string(e.c_str()) + "\n";
}

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
