// Writing the reopenable map (include/hazmap/map/map_folder.hpp): keyframe clouds, classes.yaml
// and, last, map.json with every file's size and checksum.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/map/map_folder.hpp"
#include "map/map_folder_json.hpp"

namespace hazmap {

namespace fs = std::filesystem;
using namespace map_folder_detail;

std::uint64_t fileChecksum(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path.string(), "cannot open");
  std::uint64_t h = 0xcbf29ce484222325ULL;
  char buf[1 << 16];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    for (std::streamsize i = 0; i < in.gcount(); ++i) {
      h ^= static_cast<unsigned char>(buf[i]);
      h *= 0x100000001b3ULL;
    }
    if (!in) break;
  }
  return h;
}

double sensorHeightAboveFloor(const LabeledCloud& cloud) {
  // The floor around a ground robot is the lowest large surface near it: the 5th percentile of
  // the nearby points' heights ignores a few returns from below (drains, noise).
  constexpr double kRadius = 6.0;
  constexpr std::size_t kMinPoints = 200;
  std::vector<float> z;
  for (const auto& p : cloud.points)
    if (p.allFinite() && p.head<2>().squaredNorm() <= kRadius * kRadius) z.push_back(p.z());
  if (z.size() < kMinPoints) return std::numeric_limits<double>::quiet_NaN();
  const auto k = z.begin() + static_cast<std::ptrdiff_t>(z.size() / 20);
  std::nth_element(z.begin(), k, z.end());
  return -static_cast<double>(*k);
}

void invalidateMapFolder(const fs::path& dir) {
  std::error_code ec;
  fs::remove(dir / "map.json", ec);
  if (ec) fail((dir / "map.json").string(), "cannot remove the previous manifest: " + ec.message());
}

namespace {

// keyframes/NNNNNN.pcd, the folder created.
std::string keyframeCloudName(const fs::path& dir, std::size_t frame) {
  char name[32];
  std::snprintf(name, sizeof name, "keyframes/%06zu.pcd", frame);
  std::error_code ec;
  fs::create_directories(dir / "keyframes", ec);
  if (ec) fail((dir / "keyframes").string(), "cannot create: " + ec.message());
  return name;
}

}  // namespace

std::string writeMapKeyframeCloud(const fs::path& dir, std::size_t frame, const LabeledCloud& cloud) {
  const std::string name = keyframeCloudName(dir, frame);
  writePcd(dir / name, cloud, PcdEncoding::BinaryCompressed);
  return name;
}

std::string copyMapKeyframeCloud(const fs::path& dir, std::size_t frame, const fs::path& from) {
  const std::string name = keyframeCloudName(dir, frame);
  std::error_code ec;
  fs::copy_file(from, dir / name, fs::copy_options::overwrite_existing, ec);
  if (ec) fail(from.string(), "cannot copy into " + (dir / name).string() + ": " + ec.message());
  return name;
}

void writeMapManifest(const fs::path& dir, const MapManifest& manifest, const ClassTable& classes,
                      const std::vector<std::string>& files, const std::string& graph_extras) {
  writeTextAtomically(dir / "classes.yaml", classes.toYamlString());
  std::vector<std::string> listed = files;
  listed.push_back("classes.yaml");
  if (!graph_extras.empty()) listed.push_back(graph_extras);
  nlohmann::json keyframes = nlohmann::json::array();
  for (const auto& k : manifest.keyframes) {
    keyframes.push_back(keyframeJson(k));
    listed.push_back(k.cloud);
  }
  if (manifest.search_overview) listed.push_back(manifest.search_overview->cloud);
  nlohmann::json file_list = nlohmann::json::array();
  for (const auto& f : listed) {
    std::error_code ec;
    const auto bytes = fs::file_size(dir / f, ec);
    if (ec) fail((dir / f).string(), "missing while writing map.json: " + ec.message());
    file_list.push_back({{"path", f}, {"bytes", bytes}, {"fnv1a", hex64(fileChecksum(dir / f))}});
  }
  nlohmann::json j;
  j["format"] = kMapFormat;
  j["method"] = manifest.method;
  j["source"] = manifest.source;
  j["frames"] = manifest.frames;
  j["classes"] = "classes.yaml";
  j["sensor_height_m"] = std::isfinite(manifest.sensor_height) ? nlohmann::json(manifest.sensor_height) : nlohmann::json();
  j["graph"] = "graph.g2o";
  if (!graph_extras.empty()) j["graph_extras"] = graph_extras;
  j["hazards"] = "hazards.json";
  j["trajectory"] = "trajectory.kitti";
  j["parameters"] = nlohmann::json::parse(manifest.parameters_json);
  j["keyframes"] = std::move(keyframes);
  if (const auto& o = manifest.search_overview)
    j["search_overview"] = {{"cloud", o->cloud}, {"voxel", o->voxel}, {"property_classes", o->property_classes}};
  j["files"] = std::move(file_list);
  writeTextAtomically(dir / "map.json", j.dump(1) + "\n");
}

}  // namespace hazmap
