// map.json read on its own (map/map_folder_json.hpp, parseMapManifest): what openMap checks
// before it looks at the folder's files. A file of its own so the fuzz target links only this.
#include <limits>

#include "hazmap/core/error.hpp"
#include "map/map_folder_json.hpp"

namespace hazmap::map_folder_detail {

namespace fs = std::filesystem;

namespace {

// The pieces a map cannot do without, each named in map.json.
constexpr const char* kRequiredKeys[] = {"format", "frames", "classes", "graph", "hazards", "trajectory",
                                         "keyframes", "files", "parameters"};

void requireListed(const fs::path& dir, const std::vector<MapFileEntry>& files, const std::string& path,
                   const std::string& what) {
  for (const auto& f : files)
    if (f.path == path) return;
  fail(dir.string(), "map.json names " + what + " '" + path + "' but does not list it among its files");
}

void readManifest(const fs::path& dir, const nlohmann::json& j, MapManifest& m) {
  for (const char* key : kRequiredKeys)
    if (!j.contains(key)) fail((dir / "map.json").string(), std::string("missing '") + key + "'");
  m.format = j.at("format").get<std::string>();
  if (m.format != kMapFormat)
    fail((dir / "map.json").string(), "format '" + m.format + "' is not supported (this hazmap reads " + kMapFormat + ")");
  m.method = j.value("method", "");
  m.source = j.value("source", "");
  m.frames = j.at("frames").get<std::size_t>();
  const auto& h = j.value("sensor_height_m", nlohmann::json());
  m.sensor_height = h.is_number() ? h.get<double>() : std::numeric_limits<double>::quiet_NaN();
  m.parameters_json = j.at("parameters").dump();
  if (j.contains("search_overview")) {
    const auto& o = j.at("search_overview");
    m.search_overview = MapSearchOverview{o.at("cloud").get<std::string>(), o.at("voxel").get<double>(),
                                          o.at("property_classes").get<std::vector<ClassId>>()};
    if (!(m.search_overview->voxel > 0.0)) throw std::invalid_argument("search_overview voxel must be positive");
  }
  for (const auto& k : j.at("keyframes")) {
    m.keyframes.push_back(keyframeFromJson(k));
    if (m.keyframes.back().frame >= m.frames)
      throw std::invalid_argument("keyframe frame " + std::to_string(m.keyframes.back().frame) + " beyond the run's frames");
  }
}

std::vector<MapFileEntry> listedFiles(const fs::path& dir, const nlohmann::json& list) {
  std::vector<MapFileEntry> files;
  for (const auto& f : list) {
    MapFileEntry e{f.at("path").get<std::string>(), f.at("bytes").get<std::uintmax_t>(),
                   parseHex64(f.at("fnv1a").get<std::string>())};
    if (fs::path(e.path).is_absolute() || e.path.find("..") != std::string::npos || e.path.empty())
      fail(dir.string(), "map.json lists '" + e.path + "', outside the folder");
    files.push_back(std::move(e));
  }
  return files;
}

}  // namespace

ParsedMapManifest parseMapManifest(const std::string& text, const fs::path& dir) {
  ParsedMapManifest p;
  try {
    const nlohmann::json j = nlohmann::json::parse(text);
    if (!j.is_object()) throw std::invalid_argument("not a JSON object");
    readManifest(dir, j, p.manifest);
    p.files = listedFiles(dir, j.at("files"));
    p.classes = j.at("classes").get<std::string>();
    p.graph = j.at("graph").get<std::string>();
    p.hazards = j.at("hazards").get<std::string>();
    p.trajectory = j.at("trajectory").get<std::string>();
    if (j.contains("graph_extras")) p.graph_extras = j.at("graph_extras").get<std::string>();
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    fail((dir / "map.json").string(), std::string("broken manifest: ") + e.what());
  }
  requireListed(dir, p.files, p.classes, "the class table");
  requireListed(dir, p.files, p.graph, "the pose graph");
  requireListed(dir, p.files, p.hazards, "the hazards");
  requireListed(dir, p.files, p.trajectory, "the trajectory");
  if (!p.graph_extras.empty()) requireListed(dir, p.files, p.graph_extras, "the graph's extras");
  for (const auto& k : p.manifest.keyframes) requireListed(dir, p.files, k.cloud, "a keyframe cloud");
  if (const auto& o = p.manifest.search_overview) requireListed(dir, p.files, o->cloud, "the search overview");
  return p;
}

}  // namespace hazmap::map_folder_detail
