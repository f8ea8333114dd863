// Velodyne calibrations: each model's factory angles (from the manufacturer's manuals) and the
// ROS velodyne_pointcloud / nebula calibration YAML.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/velodyne.hpp"

namespace hazmap {

namespace {

constexpr double kDegToRad = M_PI / 180.0;

// Elevation (vertical angle) of each laser in the packet's channel order, degrees.
constexpr std::array<double, 16> kVlp16Elevation = {-15, 1, -13, 3,  -11, 5,  -9, 7,
                                                    -7,  9, -5,  11, -3,  13, -1, 15};
constexpr std::array<double, 32> kHdl32Elevation = {
    -30.67, -9.33, -29.33, -8.00, -28.00, -6.67, -26.67, -5.33, -25.33, -4.00, -24.00,
    -2.67,  -22.67, -1.33, -21.33, 0.00,  -20.00, 1.33,  -18.67, 2.67,  -17.33, 4.00,
    -16.00, 5.33,  -14.67, 6.67,  -13.33, 8.00,  -12.00, 9.33,  -10.67, 10.67};
constexpr std::array<double, 32> kVlp32cElevation = {
    -25,    -1,     -1.667, -15.639, -11.31, 0,     -0.667, -8.843, -7.254, 0.333, -0.333,
    -6.148, -5.333, 1.333,  0.667,   -4,     -4.667, 1.667, 1,      -3.667, -3.333, 3.333,
    2.333,  -2.667, -3,     7,       4.667,  -2.333, -2,    15,     10.333, -1.333};
// The VLP-32C manual's azimuth offsets are −rot_correction: lasers sit at ±1.4° or ±4.2°.
constexpr std::array<double, 32> kVlp32cRotCorrection = {
    -1.4, 4.2,  -1.4, 1.4, -1.4, 1.4, -4.2, 1.4, -1.4, 4.2, -1.4, 1.4, -4.2, 1.4, -4.2, 1.4,
    -1.4, 4.2,  -1.4, 4.2, -4.2, 1.4, -1.4, 1.4, -1.4, 1.4, -1.4, 4.2, -4.2, 1.4, -1.4, 1.4};
constexpr std::array<double, 128> kVls128Elevation = {
    -11.742, -1.99,  3.4,     -5.29,  -0.78,  4.61,  -4.08,   1.31,   -6.5,  -1.11,  4.28,
    -4.41,   0.1,    6.48,    -3.2,   2.19,   -3.86, 1.53,    -9.244, -1.77, 2.74,   -5.95,
    -0.56,   4.83,   -2.98,   2.41,   -6.28,  -0.89, 3.62,    -5.07,  0.32,  7.58,   -0.34,
    5.18,    -3.64,  1.75,    -25,    -2.43,  2.96,  -5.73,   0.54,   9.7,   -2.76,  2.63,
    -7.65,   -1.55,  3.84,    -4.85,  3.18,   -5.51, -0.12,   5.73,   -4.3,  1.09,   -16.042,
    -2.21,   4.06,   -4.63,   0.76,   15,     -3.42, 1.97,    -6.85,  -1.33, -5.62,  -0.23,
    5.43,    -3.53,  0.98,    -19.582, -2.32, 3.07,  -4.74,   0.65,   11.75, -2.65,  1.86,
    -7.15,   -1.44,  3.95,    -2.1,   3.29,   -5.4,  -0.01,   4.5,    -4.19, 1.2,    -13.565,
    -1.22,   4.17,   -4.52,   0.87,   6.08,   -3.31, 2.08,    -6.65,  1.42,  -10.346, -1.88,
    3.51,    -6.06,  -0.67,   4.72,   -3.97,  2.3,   -6.39,   -1,     4.39,  -5.18,  0.21,
    6.98,    -3.09,  4.98,    -3.75,  1.64,   -8.352, -2.54,  2.85,   -5.84, -0.45,  8.43,
    -2.87,   2.52,   -6.17,   -1.66,  3.73,   -4.96, 0.43};
// VLS-128: the eight lasers of a firing group sit at eight azimuths, repeated for every group.
constexpr std::array<double, 8> kVls128RotCorrection = {-6.354, -4.548, -2.732, -0.911,
                                                        0.911,  2.732,  4.548,  6.354};

/// Ring numbers: lasers ordered by elevation, 0 = lowest (ties keep laser order).
void assignRings(std::vector<VelodyneLaser>& lasers) {
  std::vector<std::size_t> order(lasers.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return lasers[a].vert_correction < lasers[b].vert_correction;
  });
  for (std::size_t r = 0; r < order.size(); ++r)
    lasers[order[r]].ring = static_cast<std::uint16_t>(r);
}

template <std::size_t N>
std::vector<VelodyneLaser> fromDegrees(const std::array<double, N>& elevation,
                                       const double* rot_correction, std::size_t rot_period) {
  std::vector<VelodyneLaser> lasers(N);
  for (std::size_t i = 0; i < N; ++i) {
    lasers[i].vert_correction = elevation[i] * kDegToRad;
    if (rot_correction) lasers[i].rot_correction = rot_correction[i % rot_period] * kDegToRad;
  }
  return lasers;
}

double required(const YAML::Node& node, const char* key, const std::string& where) {
  const YAML::Node v = node[key];
  if (!v) fail(where, std::string("missing '") + key + "'");
  try {
    const double x = v.as<double>();
    if (!std::isfinite(x)) fail(where, std::string("'") + key + "' is not finite");
    return x;
  } catch (const YAML::Exception&) {
    fail(where, std::string("'") + key + "' is not a number");
  }
}

double optional(const YAML::Node& node, const char* key, double fallback, const std::string& where) {
  return node[key] ? required(node, key, where) : fallback;
}

VelodyneLaser parseLaser(const YAML::Node& node, const std::string& where) {
  VelodyneLaser l;
  l.rot_correction = required(node, "rot_correction", where);
  l.vert_correction = required(node, "vert_correction", where);
  l.dist_correction = optional(node, "dist_correction", 0.0, where);
  l.dist_correction_x = optional(node, "dist_correction_x", 0.0, where);
  l.dist_correction_y = optional(node, "dist_correction_y", 0.0, where);
  l.two_pt_correction_available =
      node["two_pt_correction_available"] && node["two_pt_correction_available"].as<bool>();
  l.vert_offset_correction = optional(node, "vert_offset_correction", 0.0, where);
  l.horiz_offset_correction = optional(node, "horiz_offset_correction", 0.0, where);
  // The ROS reader floors the intensity bounds.
  l.min_intensity = std::floor(optional(node, "min_intensity", 0.0, where));
  l.max_intensity = std::floor(optional(node, "max_intensity", 255.0, where));
  l.focal_distance = optional(node, "focal_distance", 0.0, where);
  l.focal_slope = optional(node, "focal_slope", 0.0, where);
  if (std::abs(l.vert_correction) > M_PI / 2 || std::abs(l.rot_correction) > 2 * M_PI)
    fail(where, "angle out of range (the file's angles are radians)");
  return l;
}

}  // namespace

const char* velodyneModelName(VelodyneModel model) {
  switch (model) {
    case VelodyneModel::VLP16: return "VLP-16";
    case VelodyneModel::VLP32C: return "VLP-32C";
    case VelodyneModel::HDL32E: return "HDL-32E";
    case VelodyneModel::VLS128: return "VLS-128";
  }
  return "unknown";
}

std::optional<VelodyneModel> velodyneModelFromProductId(std::uint8_t product_id) {
  switch (product_id) {
    case 0x21: return VelodyneModel::HDL32E;
    case 0x22: return VelodyneModel::VLP16;
    case 0x28: return VelodyneModel::VLP32C;
    case 0xA1: return VelodyneModel::VLS128;
    default: return std::nullopt;
  }
}

int velodyneLaserCount(VelodyneModel model) {
  switch (model) {
    case VelodyneModel::VLP16: return 16;
    case VelodyneModel::VLP32C:
    case VelodyneModel::HDL32E: return 32;
    case VelodyneModel::VLS128: return 128;
  }
  return 0;
}

VelodyneCalibration velodyneFactoryCalibration(VelodyneModel model) {
  VelodyneCalibration c;
  c.model = model;
  c.source = "factory";
  switch (model) {
    case VelodyneModel::VLP16:
      c.lasers = fromDegrees(kVlp16Elevation, nullptr, 1);
      break;
    case VelodyneModel::HDL32E:
      c.lasers = fromDegrees(kHdl32Elevation, nullptr, 1);
      break;
    case VelodyneModel::VLP32C:
      c.distance_resolution = 0.004;
      c.lasers = fromDegrees(kVlp32cElevation, kVlp32cRotCorrection.data(), 32);
      break;
    case VelodyneModel::VLS128:
      c.distance_resolution = 0.004;
      c.lasers = fromDegrees(kVls128Elevation, kVls128RotCorrection.data(), 8);
      break;
  }
  assignRings(c.lasers);
  return c;
}

VelodyneCalibration loadVelodyneCalibration(const std::filesystem::path& path, VelodyneModel model) {
  const std::string where = path.string();
  YAML::Node doc;
  try {
    doc = YAML::LoadFile(path.string());
  } catch (const YAML::BadFile&) {
    fail(where, "cannot open the Velodyne calibration file");
  } catch (const YAML::Exception& e) {
    fail(where, "not valid YAML (line " + std::to_string(e.mark.line + 1) + ")");
  }
  if (!doc.IsMap() || !doc["lasers"] || !doc["lasers"].IsSequence())
    fail(where, "not a Velodyne calibration (no 'lasers' list)");
  const int expected = velodyneLaserCount(model);
  const YAML::Node lasers = doc["lasers"];
  if (static_cast<int>(lasers.size()) != expected)
    fail(where, std::to_string(lasers.size()) + " lasers, but a " + velodyneModelName(model) +
                    " has " + std::to_string(expected));
  if (doc["num_lasers"] && doc["num_lasers"].as<int>(-1) != expected)
    fail(where, "num_lasers is not " + std::to_string(expected));
  VelodyneCalibration c = velodyneFactoryCalibration(model);
  c.source = where;
  // The VLS-128's range unit is fixed at 4 mm by the packet format (nebula's file says 7 mm and
  // its decoder ignores it); the other models take the file's value.
  if (doc["distance_resolution"] && model != VelodyneModel::VLS128) {
    c.distance_resolution = required(doc, "distance_resolution", where);
    if (!(c.distance_resolution > 0 && c.distance_resolution < 1))
      fail(where, "distance_resolution out of range");
  }
  std::vector<bool> seen(expected, false);
  for (std::size_t i = 0; i < lasers.size(); ++i) try {
    const std::string at = where + ": lasers[" + std::to_string(i) + "]";
    if (!lasers[i].IsMap()) fail(at, "not a map");
    const double id = required(lasers[i], "laser_id", at);
    if (id < 0 || id >= expected || id != std::floor(id))
      fail(at, "laser_id " + std::to_string(id) + " out of range");
    if (seen[static_cast<int>(id)]) fail(at, "laser_id repeated");
    seen[static_cast<int>(id)] = true;
    c.lasers[static_cast<int>(id)] = parseLaser(lasers[i], at);
  } catch (const YAML::Exception&) {
    fail(where + ": lasers[" + std::to_string(i) + "]", "a field of the wrong type");
  }
  assignRings(c.lasers);
  return c;
}

}  // namespace hazmap
