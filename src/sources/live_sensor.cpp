#include <algorithm>
#include <cctype>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/hesai.hpp"
#include "hazmap/sources/live_source.hpp"
#include "hazmap/sources/velodyne.hpp"

namespace hazmap {

LiveSensor liveSensorNamed(const std::string& name) {
  std::string lower = name;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  if (lower == "velodyne") return LiveSensor::Velodyne;
  if (lower == "hesai") return LiveSensor::Hesai;
  if (lower == "ouster") return LiveSensor::Ouster;
  if (hesaiModelFromName(name)) return LiveSensor::Hesai;
  for (VelodyneModel m : {VelodyneModel::VLP16, VelodyneModel::VLP32C, VelodyneModel::HDL32E, VelodyneModel::VLS128})
    if (name == velodyneModelName(m)) return LiveSensor::Velodyne;
  fail("--sensor", "'" + name + "' is no sensor hazmap live reads: velodyne, ouster, hesai, or a model name "
                                "(VLP-16, VLP-32C, HDL-32E, VLS-128, Pandar40P, Pandar64, PandarQT64, PandarQT128, "
                                "PandarXT16, PandarXT32, PandarXT32M)");
}

const char* toString(LiveSensor sensor) {
  switch (sensor) {
    case LiveSensor::Velodyne: return "velodyne";
    case LiveSensor::Hesai: return "hesai";
    case LiveSensor::Ouster: return "ouster";
  }
  return "?";
}

std::uint16_t standardDataPort(LiveSensor sensor) { return sensor == LiveSensor::Ouster ? 7502 : 2368; }

std::uint16_t standardAuxiliaryPort(LiveSensor sensor) {
  switch (sensor) {
    case LiveSensor::Velodyne: return 8308;
    case LiveSensor::Hesai: return 10110;
    case LiveSensor::Ouster: return 7503;
  }
  return 0;
}

}  // namespace hazmap
