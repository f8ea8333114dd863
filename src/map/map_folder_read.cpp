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

// The listed files present with their sizes and checksums (the checksums side by side: reading
// every byte is most of opening a large map, 379 MB at 972 keyframes). The first mismatch in the
// list's order is the one reported.
void checkFiles(const fs::path& dir, const std::vector<MapFileEntry>& files) {
  for (const auto& e : files) {
    std::error_code ec;
    const auto bytes = fs::file_size(dir / e.path, ec);
    if (ec) fail(dir.string(), "partially written or damaged map: " + e.path + " is missing");
    if (bytes != e.bytes)
      fail(dir.string(), "partially written or damaged map: " + e.path + " has " + std::to_string(bytes) +
                             " bytes, map.json says " + std::to_string(e.bytes));
  }
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
}

}  // namespace

MapFolder openMap(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) fail(dir.string(), "no such map folder");
  if (!fs::exists(dir / "map.json", ec))
    fail(dir.string(), "not a hazmap map: map.json is missing (a run of an older hazmap, or one that did not finish)");
  ParsedMapManifest parsed = parseMapManifest(readTextFile(dir / "map.json"), dir);
  checkFiles(dir, parsed.files);
  MapFolder map;
  map.dir_ = dir;
  map.manifest_ = std::move(parsed.manifest);
  map.files_ = std::move(parsed.files);
  map.graph_extras_ = std::move(parsed.graph_extras);
  map.classes_ = ClassTable::fromYamlString(readTextFile(dir / parsed.classes), (dir / parsed.classes).string());
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
