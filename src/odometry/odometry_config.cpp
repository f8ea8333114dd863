// OdometryConfig from YAML.
#include <yaml-cpp/yaml.h>

#include <fstream>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/odometry/odometry.hpp"

namespace hazmap {

OdometryConfig odometryConfigFromYaml(const std::string& yaml, const std::string& where,
                                      const OdometryConfig& base) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    fail(where, std::string("invalid YAML: ") + e.msg + " at line " + std::to_string(e.mark.line + 1));
  }
  OdometryConfig c = base;
  if (!root || root.IsNull()) return c;
  if (!root.IsMap()) fail(where, "odometry config must be a YAML mapping");
  if (root["odometry"] && root["odometry"].IsMap()) root = root["odometry"];
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    const YAML::Node& v = kv.second;
    const auto get = [&](auto& field, const std::string& name) {
      try {
        field = v.as<std::remove_reference_t<decltype(field)>>();
      } catch (const YAML::Exception&) {
        fail(where, "bad value for '" + name + "'");
      }
    };
    if (key == "mode") {
      std::string s;
      get(s, key);
      if (s == "frame") c.mode = OdometryMode::FrameToFrame;
      else if (s == "map") c.mode = OdometryMode::FrameToMap;
      else fail(where, "mode must be 'frame' or 'map' (got '" + s + "')");
    } else if (key == "min_range") get(c.min_range, key);
    else if (key == "max_range") get(c.max_range, key);
    else if (key == "voxel_size") get(c.voxel_size, key);
    else if (key == "source_voxel_size") get(c.source_voxel_size, key);
    else if (key == "min_fitness") get(c.min_fitness, key);
    else if (key == "max_correction_translation") get(c.max_correction_translation, key);
    else if (key == "max_correction_rotation") get(c.max_correction_rotation, key);
    else if (key == "keep_guess_along_degenerate") get(c.keep_guess_along_degenerate, key);
    else if (key == "fallback_sigma_translation") get(c.fallback_sigma_translation, key);
    else if (key == "fallback_sigma_rotation") get(c.fallback_sigma_rotation, key);
    else if (key == "map") {
      if (!v.IsMap()) fail(where, "'map' must be a mapping");
      for (const auto& m : v) {
        const std::string k = m.first.as<std::string>();
        const YAML::Node& mv = m.second;
        const auto getm = [&](auto& field) {
          try {
            field = mv.as<std::remove_reference_t<decltype(field)>>();
          } catch (const YAML::Exception&) {
            fail(where, "bad value for 'map." + k + "'");
          }
        };
        if (k == "voxel_size") getm(c.map.voxel_size);
        else if (k == "max_points_per_voxel") getm(c.map.max_points_per_voxel);
        else if (k == "min_point_distance") getm(c.map.min_point_distance);
        else if (k == "max_distance") getm(c.map.max_distance);
        else if (k == "normal_updates") getm(c.map.normal_updates);
        else fail(where, "unknown map setting '" + k + "'");
      }
    } else if (key == "registration") {
      YAML::Emitter out;
      out << v;
      c.registration = registrationConfigFromYaml(out.c_str(), where, c.registration);
    } else {
      fail(where, "unknown odometry setting '" + key + "'");
    }
  }
  try {
    c.validate();
  } catch (const Error& e) {
    fail(where, e.what());
  }
  return c;
}

OdometryConfig loadOdometryConfig(const std::string& path, const OdometryConfig& base) {
  std::ifstream in(path);
  if (!in) fail(path, "cannot open odometry config");
  std::stringstream ss;
  ss << in.rdbuf();
  return odometryConfigFromYaml(ss.str(), path, base);
}

}  // namespace hazmap
