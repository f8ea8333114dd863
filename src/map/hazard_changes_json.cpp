// changes.json / changes.csv (include/hazmap/map/hazard_changes.hpp): written atomically, read
// back by the viewer (`hazmap view` shows a run's or a merge's changes).
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <map>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/map/hazard_changes.hpp"

namespace hazmap {

namespace {

nlohmann::json rangesJson(const std::vector<FrameRange>& r) {
  nlohmann::json j = nlohmann::json::array();
  for (const auto& f : r) j.push_back({f.first, f.last});
  return j;
}

nlohmann::json optionalXyz(const std::optional<Eigen::Vector3d>& p) {
  return p ? nlohmann::json{p->x(), p->y(), p->z()} : nlohmann::json();
}

nlohmann::json optionalValue(const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(); }

std::string csvRanges(const std::vector<FrameRange>& r) {
  std::string s;
  for (const auto& f : r) s += (s.empty() ? "" : ";") + fmt::format("{}-{}", f.first, f.last);
  return s;
}

std::string joined(const std::vector<std::string>& kinds) {
  std::string s;
  for (const auto& k : kinds) s += (s.empty() ? "" : ";") + k;
  return s;
}

}  // namespace

std::string hazardChangeJson(const HazardChange& c) {
  nlohmann::json j = {{"kinds", c.kinds}, {"class", c.class_name}, {"before_id", c.before_id}, {"after_id", c.after_id},
                      {"before", optionalXyz(c.before)}, {"after", optionalXyz(c.after)}, {"moved_m", c.moved_m},
                      {"area_before_m2", c.area_before_m2}, {"area_after_m2", c.area_after_m2},
                      {"value_before", optionalValue(c.value_before)}, {"value_after", optionalValue(c.value_after)},
                      {"frames_before", rangesJson(c.frames_before)}, {"frames_after", rangesJson(c.frames_after)},
                      {"confidence", c.confidence}};
  if (c.mission > 0) j["mission"] = c.mission;
  return j.dump();
}

void writeHazardChanges(const std::filesystem::path& dir, const std::vector<HazardChange>& changes) {
  nlohmann::json list = nlohmann::json::array();
  std::map<std::string, std::size_t> counts;
  const bool missions = std::any_of(changes.begin(), changes.end(), [](const HazardChange& c) { return c.mission > 0; });
  std::string csv = std::string(missions ? "mission," : "") + "kinds,class,before_id,after_id,before_x,before_y,before_z,after_x,after_y,after_z,moved_m,"
                    "area_before_m2,area_after_m2,value_before,value_after,frames_before,frames_after,confidence\n";
  const auto xyz = [](const std::optional<Eigen::Vector3d>& p) {
    return p ? fmt::format("{:.3f},{:.3f},{:.3f}", p->x(), p->y(), p->z()) : std::string(",,");
  };
  const auto value = [](const std::optional<double>& v) { return v ? fmt::format("{:.3f}", *v) : std::string(); };
  for (const auto& c : changes) {
    for (const auto& k : c.kinds) ++counts[k];
    list.push_back(nlohmann::json::parse(hazardChangeJson(c)));
    if (missions) csv += fmt::format("{},", c.mission);
    csv += fmt::format("{},{},{},{},{},{},{:.3f},{:.3f},{:.3f},{},{},{},{},{:.2f}\n", joined(c.kinds), c.class_name,
                       c.before_id, c.after_id, xyz(c.before), xyz(c.after), c.moved_m, c.area_before_m2,
                       c.area_after_m2, value(c.value_before), value(c.value_after), csvRanges(c.frames_before),
                       csvRanges(c.frames_after), c.confidence);
  }
  writeTextAtomically(dir / "changes.json", nlohmann::json{{"changes", list}, {"counts", counts}}.dump(2) + "\n");
  writeTextAtomically(dir / "changes.csv", csv);
}


namespace {

std::optional<Eigen::Vector3d> optionalXyzFrom(const nlohmann::json& j) {
  if (j.is_null()) return std::nullopt;
  if (!j.is_array() || j.size() != 3) throw std::invalid_argument("a position is [x, y, z] or null");
  return Eigen::Vector3d(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
}

std::optional<double> optionalValueFrom(const nlohmann::json& j) {
  return j.is_null() ? std::nullopt : std::optional<double>(j.get<double>());
}

std::vector<FrameRange> rangesFrom(const nlohmann::json& j) {
  std::vector<FrameRange> r;
  for (const auto& f : j) r.push_back({f.at(0).get<std::uint32_t>(), f.at(1).get<std::uint32_t>()});
  return r;
}

HazardChange changeFrom(const nlohmann::json& j) {
  HazardChange c;
  c.kinds = j.at("kinds").get<std::vector<std::string>>();
  c.class_name = j.at("class").get<std::string>();
  c.before_id = j.at("before_id").get<int>();
  c.after_id = j.at("after_id").get<int>();
  c.before = optionalXyzFrom(j.at("before"));
  c.after = optionalXyzFrom(j.at("after"));
  c.moved_m = j.at("moved_m").get<double>();
  c.area_before_m2 = j.at("area_before_m2").get<double>();
  c.area_after_m2 = j.at("area_after_m2").get<double>();
  c.value_before = optionalValueFrom(j.at("value_before"));
  c.value_after = optionalValueFrom(j.at("value_after"));
  c.frames_before = rangesFrom(j.at("frames_before"));
  c.frames_after = rangesFrom(j.at("frames_after"));
  c.confidence = j.at("confidence").get<double>();
  c.mission = j.value("mission", 0);
  return c;
}

}  // namespace

std::vector<HazardChange> readHazardChanges(const std::filesystem::path& path) {
  std::vector<HazardChange> changes;
  try {
    const nlohmann::json j = nlohmann::json::parse(readTextFile(path));
    for (const auto& c : j.at("changes")) changes.push_back(changeFrom(c));
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    fail(path.string(), std::string("broken changes file: ") + e.what());
  }
  return changes;
}

}  // namespace hazmap
