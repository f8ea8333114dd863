#pragma once
// Everything a run writes about its map, in one call: map.ply, map.pcd, hazards.json,
// hazards.csv, map_top.png, trajectory.png and viewer.html (all atomic), so `hazmap run`,
// `hazmap demo` and library users produce the same files.
#include <map>
#include <filesystem>
#include <string>
#include <vector>

#include "hazmap/io/trajectory.hpp"
#include "hazmap/map/global_map.hpp"
#include "hazmap/map/hazards.hpp"
#include "hazmap/map/render.hpp"
#include "hazmap/map/viewer.hpp"

namespace hazmap {

struct MapOutputConfig {
  HazardConfig hazards;
  TopDownConfig top_down;     ///< cell_size is taken from the map when left at 0
  TrajectoryPlotConfig plot;
  bool write_ply = true;
  bool write_pcd = true;
  bool write_hazards = true;
  bool write_pngs = true;
  /// viewer.html (`hazmap view`'s page); a map too large for viewer.max_bytes is decimated.
  bool write_viewer = false;
  ViewerConfig viewer;
  std::string viewer_title;  ///< empty = top_down.title
  /// What changed since the prior mission, shown as the viewer's changes layer and table.
  std::vector<HazardChange> changes;
  /// Per camera channel, the cameras that gave it (hazards.json's `channels`); channels of
  /// the map not listed here are reported without cameras.
  std::map<std::string, std::vector<std::string>> channel_cameras;
};

struct MapOutputs {
  LabeledCloud cloud;  ///< the map as written (map.cloud())
  std::vector<Hazard> hazards;
  std::vector<std::filesystem::path> files;  ///< every file written, in order
};

/// Writes the map files into `dir` (which must exist). `estimate` is drawn on map_top.png and
/// in trajectory.png; `ground_truth` and `odometry` (optional, same length as the estimate)
/// are added to trajectory.png. Throws hazmap::Error naming the file on failure.
MapOutputs writeMapOutputs(const std::filesystem::path& dir, const GlobalMap& map,
                           const Trajectory& estimate, const Trajectory* ground_truth = nullptr,
                           const Trajectory* odometry = nullptr, const MapOutputConfig& config = {});

}  // namespace hazmap
