// hazards.json read back (the viewer's input). Kept apart from the inventory so that the fuzz
// target links only io and core.
#include <nlohmann/json.hpp>

#include <cmath>
#include <limits>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/map/hazards.hpp"

namespace hazmap {

namespace {

Eigen::Vector3d vec3(const nlohmann::json& j, const char* key) {
  const auto& a = j.at(key);
  if (!a.is_array() || a.size() != 3) throw std::invalid_argument(std::string(key) + " is not 3 numbers");
  Eigen::Vector3d v(a.at(0).get<double>(), a.at(1).get<double>(), a.at(2).get<double>());
  if (!v.allFinite()) throw std::invalid_argument(std::string(key) + " is not finite");
  return v;
}

// A whole number in [0, max] (nlohmann's own conversion of 1e300 to an integer is undefined).
std::uint64_t count(const nlohmann::json& j, const char* key, std::uint64_t max, bool required = false) {
  if (!j.contains(key)) {
    if (required) throw std::invalid_argument(std::string("missing ") + key);
    return 0;
  }
  const auto& v = j.at(key);
  if (!v.is_number_unsigned() && !(v.is_number_integer() && v.get<std::int64_t>() >= 0))
    throw std::invalid_argument(std::string(key) + " is not a count");
  const std::uint64_t n = v.get<std::uint64_t>();
  if (n > max) throw std::invalid_argument(std::string(key) + " is out of range");
  return n;
}

double number(const nlohmann::json& j, const char* key) {
  if (!j.contains(key)) return 0.0;
  const double v = j.at(key).get<double>();
  if (!std::isfinite(v)) throw std::invalid_argument(std::string(key) + " is not finite");
  return v;
}

Hazard hazardFromJson(const nlohmann::json& j) {
  Hazard h;
  h.id = int(count(j, "id", std::numeric_limits<int>::max(), true));
  h.class_name = j.at("class").get<std::string>();
  h.label = ClassId(count(j, "class_id", std::numeric_limits<ClassId>::max()));
  h.kind = parsePropertyKind(j.at("kind").get<std::string>()).value_or(PropertyKind::Other);
  h.centroid = vec3(j, "centroid");
  h.min = vec3(j, "min");
  h.max = vec3(j, "max");
  h.area_m2 = number(j, "area_m2");
  h.cells = count(j, "cells", std::numeric_limits<std::uint32_t>::max());
  h.points = count(j, "points", std::numeric_limits<std::uint64_t>::max());
  if (j.contains("mean_property") && j["mean_property"].is_number()) h.mean_property = number(j, "mean_property");
  if (j.contains("max_property") && j["max_property"].is_number()) h.max_property = number(j, "max_property");
  h.frame_count = count(j, "frame_count", std::numeric_limits<std::uint32_t>::max());
  if (j.contains("frames"))
    for (const auto& r : j.at("frames")) {
      if (!r.is_array() || r.size() != 2) throw std::invalid_argument("frames holds a range that is not [first, last]");
      const nlohmann::json range{{"first", r[0]}, {"last", r[1]}};
      const auto max = std::numeric_limits<std::uint32_t>::max();
      h.frames.push_back({std::uint32_t(count(range, "first", max)), std::uint32_t(count(range, "last", max))});
    }
  if (j.contains("channels")) {
    const auto& channels = j.at("channels");
    if (!channels.is_object()) throw std::invalid_argument("channels is not a mapping of channel names");
    for (const auto& [name, c] : channels.items()) {
      if (!c.is_object()) throw std::invalid_argument("channel " + name + " is not {mean, max, samples}");
      HazardChannel hc{name, std::nullopt, std::nullopt, 0};
      if (c.contains("mean") && c["mean"].is_number()) hc.mean = number(c, "mean");
      if (c.contains("max") && c["max"].is_number()) hc.max = number(c, "max");
      hc.samples = count(c, "samples", std::numeric_limits<std::uint64_t>::max());
      h.channels.push_back(std::move(hc));
    }
  }
  return h;
}

}  // namespace

std::vector<Hazard> readHazardsJson(const std::filesystem::path& path) {
  const std::string text = readTextFile(path);
  std::vector<Hazard> out;
  try {
    const nlohmann::json j = nlohmann::json::parse(text);
    const auto& list = j.at("hazards");
    if (!list.is_array()) throw std::invalid_argument("hazards is not a list");
    for (const auto& h : list) out.push_back(hazardFromJson(h));
  } catch (const std::exception& e) {
    fail(path.string(), std::string("not a hazards.json: ") + e.what());
  }
  return out;
}

}  // namespace hazmap
