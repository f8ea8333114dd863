#include "hazmap/map/outputs.hpp"

#include <limits>

#include "hazmap/core/error.hpp"
#include "hazmap/map/export.hpp"

namespace hazmap {

namespace {

/// Every named channel of the map as a per-point field of map.ply: the mean over each cell's
/// property points (NaN where the cell has none), so each camera's channel is stored, not only
/// the first (which is also the `property` field).
std::vector<std::pair<std::string, std::vector<float>>> channelFields(const GlobalMap& map) {
  std::vector<std::pair<std::string, std::vector<float>>> fields;
  const auto& names = map.channelNames();
  if (names.empty()) return fields;
  const std::vector<MapCell> cells = map.cells();
  for (std::size_t k = 0; k < names.size(); ++k) {
    std::vector<float> values(cells.size(), std::numeric_limits<float>::quiet_NaN());
    for (std::size_t i = 0; i < cells.size(); ++i)
      if (k < cells[i].channels.size() && cells[i].channels[k].samples > 0) values[i] = cells[i].channels[k].mean;
    fields.emplace_back(names[k], std::move(values));
  }
  return fields;
}

std::vector<HazardChannelInfo> mapChannels(const GlobalMap& map,
                                           const std::map<std::string, std::vector<std::string>>& cameras) {
  std::vector<HazardChannelInfo> out;
  for (const std::string& name : map.channelNames()) {
    const auto it = cameras.find(name);
    out.push_back({name, it == cameras.end() ? std::vector<std::string>{} : it->second});
  }
  return out;
}

}  // namespace

MapOutputs writeMapOutputs(const std::filesystem::path& dir, const GlobalMap& map,
                           const Trajectory& estimate, const Trajectory* ground_truth,
                           const Trajectory* odometry, const MapOutputConfig& config) {
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) fail(dir.string(), "output folder does not exist");
  MapOutputs out;
  out.cloud = map.cloud();
  const LabeledCloud& cloud = out.cloud;
  const ClassTable& table = map.classTable();
  if (config.write_ply) {
    writeMapPly(dir / "map.ply", cloud, table, config.top_down.colors, channelFields(map));
    out.files.push_back(dir / "map.ply");
  }
  if (config.write_pcd) {
    writeMapPcd(dir / "map.pcd", cloud);
    out.files.push_back(dir / "map.pcd");
  }
  out.hazards = findHazards(map, config.hazards);
  if (config.write_hazards) {
    writeHazardsJson(dir / "hazards.json", out.hazards, map.voxelSize(), mapChannels(map, config.channel_cameras));
    writeHazardsCsv(dir / "hazards.csv", out.hazards);
    out.files.push_back(dir / "hazards.json");
    out.files.push_back(dir / "hazards.csv");
  }
  if (config.write_pngs) {
    TopDownConfig top = config.top_down;
    if (top.cell_size <= 0) top.cell_size = map.voxelSize();
    writePng(dir / "map_top.png", renderTopDown(cloud, table, positionsOf(estimate), out.hazards, top));
    out.files.push_back(dir / "map_top.png");
    if (!estimate.empty()) {
      writePng(dir / "trajectory.png",
               renderTrajectoryComparison(estimate, ground_truth, odometry, config.plot));
      out.files.push_back(dir / "trajectory.png");
    }
  }
  if (config.write_viewer) {
    ViewerScene scene;
    scene.title = config.viewer_title.empty() ? config.top_down.title : config.viewer_title;
    scene.source = dir.string();
    scene.map = cloud;
    scene.classes = table;
    scene.colors = config.top_down.colors;
    scene.hazards = out.hazards;
    scene.changes = config.changes;
    scene.trajectories.push_back({"estimate", positionsOf(estimate), {208, 64, 255}});
    if (ground_truth) scene.trajectories.push_back({"ground truth", positionsOf(*ground_truth), {60, 220, 130}});
    scene.clip_above = config.top_down.clip_above;
    ViewerConfig viewer = config.viewer;
    viewer.decimate_to_fit = true;
    writeViewer(dir / "viewer.html", scene, viewer);
    out.files.push_back(dir / "viewer.html");
  }
  return out;
}

}  // namespace hazmap
