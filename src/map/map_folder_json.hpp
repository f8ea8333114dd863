#pragma once
// map.json's pieces to and from JSON (map_folder_write.cpp and map_folder_read.cpp share them).
#include <nlohmann/json.hpp>

#include "hazmap/map/map_folder.hpp"

namespace hazmap::map_folder_detail {

nlohmann::json poseJson(const Eigen::Isometry3d& pose);  ///< row-major 3×4, as a poses.txt line
Eigen::Isometry3d poseFromJson(const nlohmann::json& j);
nlohmann::json landmarkJson(const PropertyLandmark& l);
PropertyLandmark landmarkFromJson(const nlohmann::json& j);
nlohmann::json keyframeJson(const MapKeyframe& k);
MapKeyframe keyframeFromJson(const nlohmann::json& j);
std::string hex64(std::uint64_t v);
/// Applies graph_extras.json (writeGraphExtras) to `graph` read from the same map's graph.g2o.
/// Throws hazmap::Error naming the file on broken JSON or an edge or node out of range.
void readGraphExtras(const std::filesystem::path& path, PoseGraph& graph);
std::uint64_t parseHex64(const std::string& text);

/// map.json as openMap reads it, before the folder's files are looked at.
struct ParsedMapManifest {
  MapManifest manifest;
  std::vector<MapFileEntry> files;  ///< as listed, each path inside the folder
  std::string classes, graph, hazards, trajectory, graph_extras;  ///< relative paths (extras: "" = none)
};
/// map.json's text checked on its own: the required keys, the format, keyframes within the run's
/// frames, every file it names listed among its files, no listed path outside `dir`. Throws
/// hazmap::Error in one line naming `dir` or its map.json.
ParsedMapManifest parseMapManifest(const std::string& text, const std::filesystem::path& dir);

}  // namespace hazmap::map_folder_detail
