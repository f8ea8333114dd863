// Opening a reopenable map (include/hazmap/map/map_folder.hpp): the manifest first, then every
// file it lists checked for presence, size and checksum before anything is used.
#include <tbb/parallel_for.h>

#include <limits>
#include <set>

#include "hazmap/core/error.hpp"
#include "hazmap/graph/g2o.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/map/map_folder.hpp"
#include "map/map_folder_json.hpp"

namespace hazmap {

namespace fs = std::filesystem;
using namespace map_folder_detail;

namespace {

// The pieces a map cannot do without, each named in map.json.
constexpr const char* kRequiredKeys[] = {"format", "frames", "classes", "graph", "hazards", "trajectory",
                                         "keyframes", "files", "parameters"};

std::vector<MapFileEntry> checkedFiles(const fs::path& dir, const nlohmann::json& list) {
  std::vector<MapFileEntry> files;
  for (const auto& f : list) {
    MapFileEntry e{f.at("path").get<std::string>(), f.at("bytes").get<std::uintmax_t>(),
                   parseHex64(f.at("fnv1a").get<std::string>())};
    const fs::path rel(e.path);
    if (rel.is_absolute() || e.path.find("..") != std::string::npos)
      fail(dir.string(), "map.json lists '" + e.path + "', outside the folder");
    std::error_code ec;
    const auto bytes = fs::file_size(dir / rel, ec);
    if (ec) fail(dir.string(), "partially written or damaged map: " + e.path + " is missing");
    if (bytes != e.bytes)
      fail(dir.string(), "partially written or damaged map: " + e.path + " has " + std::to_string(bytes) +
                             " bytes, map.json says " + std::to_string(e.bytes));
    files.push_back(std::move(e));
  }
  // Reading every byte is most of opening a large map (a 972-keyframe map: 379 MB); the files
  // are independent. The first mismatch in the list's order is the one reported.
  std::vector<char> matches(files.size(), 0);
  std::vector<std::string> errors(files.size());
  tbb::parallel_for(std::size_t{0}, files.size(), [&](std::size_t i) {
    try {
      matches[i] = fileChecksum(dir / files[i].path) == files[i].fnv1a;
    } catch (const std::exception& e) {
      errors[i] = e.what();
    }
  });
  for (std::size_t i = 0; i < files.size(); ++i) {
    if (!errors[i].empty()) throw Error(errors[i]);
    if (!matches[i]) fail(dir.string(), "damaged map: " + files[i].path + " does not match its checksum in map.json");
  }
  return files;
}

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

}  // namespace

MapFolder openMap(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) fail(dir.string(), "no such map folder");
  if (!fs::exists(dir / "map.json", ec))
    fail(dir.string(), "not a hazmap map: map.json is missing (a run of an older hazmap, or one that did not finish)");
  MapFolder map;
  map.dir_ = dir;
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(readTextFile(dir / "map.json"));
    if (!j.is_object()) throw std::invalid_argument("not a JSON object");
    readManifest(dir, j, map.manifest_);
    map.files_ = checkedFiles(dir, j.at("files"));
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    fail((dir / "map.json").string(), std::string("broken manifest: ") + e.what());
  }
  requireListed(dir, map.files_, j.at("classes").get<std::string>(), "the class table");
  requireListed(dir, map.files_, j.at("graph").get<std::string>(), "the pose graph");
  requireListed(dir, map.files_, j.at("hazards").get<std::string>(), "the hazards");
  requireListed(dir, map.files_, j.at("trajectory").get<std::string>(), "the trajectory");
  if (j.contains("graph_extras")) {
    map.graph_extras_ = j.at("graph_extras").get<std::string>();
    requireListed(dir, map.files_, map.graph_extras_, "the graph's extras");
  }
  for (const auto& k : map.manifest_.keyframes) requireListed(dir, map.files_, k.cloud, "a keyframe cloud");
  if (const auto& o = map.manifest_.search_overview) requireListed(dir, map.files_, o->cloud, "the search overview");
  map.classes_ = ClassTable::fromYamlString(readTextFile(dir / j.at("classes").get<std::string>()),
                                            (dir / "classes.yaml").string());
  return map;
}

LabeledCloud MapFolder::loadKeyframe(std::size_t k) const {
  if (k >= manifest_.keyframes.size())
    fail(dir_.string(), "no keyframe " + std::to_string(k) + " (" + std::to_string(manifest_.keyframes.size()) + " keyframes)");
  return readPcd(dir_ / manifest_.keyframes[k].cloud, classes_);
}

LabeledCloud MapFolder::loadSearchOverview() const {
  if (!manifest_.search_overview) fail(dir_.string(), "the map has no search overview");
  return readPcd(dir_ / manifest_.search_overview->cloud, classes_);
}

PoseGraph MapFolder::graph() const {
  PoseGraph g = readG2o(dir_ / "graph.g2o");
  if (!graph_extras_.empty()) readGraphExtras(dir_ / graph_extras_, g);
  return g;
}

std::vector<Hazard> MapFolder::hazards() const { return readHazardsJson(dir_ / "hazards.json"); }

}  // namespace hazmap
