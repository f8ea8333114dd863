#pragma once
// Everything `hazmap run` writes for a finished SLAM run, each file atomically:
//   trajectory.kitti, trajectory.tum, odometry_only.kitti, graph.g2o,
//   map.ply, map.pcd, hazards.json, hazards.csv, map_top.png, trajectory.png, viewer.html,
//   run.json, and the reopenable map: keyframes/*.pcd, classes.yaml, map.json (last).
// The map is assembled in a second pass over the scans with the final poses; when the recording
// has ground truth the same pass measures the paper's map error (Table 2) and the ATE.
#include <map>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/eval/edge_nees.hpp"
#include "hazmap/eval/map_error.hpp"
#include "hazmap/eval/trajectory_metrics.hpp"
#include "hazmap/map/global_map.hpp"
#include "hazmap/map/hazards.hpp"
#include "hazmap/map/render.hpp"
#include "hazmap/pipeline/slam.hpp"

namespace hazmap {

struct OutputConfig {
  GlobalMapConfig map;        ///< voxel map with class votes (bounded by max_voxels)
  HazardConfig hazards;
  MapErrorConfig map_error;
  TopDownConfig top_down;
  /// Top-down renders hide points more than this far above the mean sensor height (m), so an
  /// indoor map is not covered by its ceiling; <= 0 draws everything.
  double render_clip_above_sensor = 1.5;
  bool write_pngs = true;
  bool write_viewer = true;  ///< viewer.html, the map in 3D in a browser (`hazmap view`)
  /// The reopenable map (map/map_folder.hpp): keyframes/, classes.yaml and, last, map.json, so a
  /// later mission can localise in this one (`hazmap run --prior`). Off, a previous map.json in
  /// the folder is still removed (the files it describes are rewritten).
  bool write_map_folder = true;
  /// Per camera channel, the cameras that gave it (hazards.json's `channels`; hazmap run --camera).
  std::map<std::string, std::vector<std::string>> channel_cameras;
};

struct RunSummary {
  std::size_t frames = 0;
  std::size_t map_cells = 0;
  std::size_t map_memory_bytes = 0;
  std::size_t hazards = 0;
  std::optional<MapErrorResult> map_error;          ///< when poses.txt exists
  std::optional<TrajectoryEvaluation> trajectory;   ///< when poses.txt exists
  std::optional<EdgeNeesReport> edge_nees;          ///< the graph's edges against the truth
  double output_seconds = 0.0;
};

/// What the demo needs to draw its side-by-side montage.
struct RunArtifacts {
  LabeledCloud map;
  std::vector<Hazard> hazards;
};

/// What a person reads at the end of `hazmap run`: frames, loops, hazards, the map error when
/// known, and where the files are.
std::string formatRunSummary(const SlamResult& result, const RunSummary& summary,
                             const std::filesystem::path& out_dir, const OutputConfig& output);

/// `scans` is a fresh stream of the run's input (the map needs a second pass over the scans);
/// the map error and the ATE are measured when every scan has a ground-truth pose.
RunSummary writeRunOutputs(ScanSource& scans, const SlamResult& result, const SlamConfig& config,
                           const OutputConfig& output, const std::filesystem::path& out_dir,
                           RunArtifacts* artifacts = nullptr);
/// The same from a map already assembled (hazmap live's saves while running: the map re-placed
/// from its segments, map/segmented_map.hpp): no second pass, so no map error, no map folder
/// (`output.write_map_folder` throws), no trajectory error. `map` must hold every frame.
RunSummary writeRunOutputs(const GlobalMap& map, const SlamResult& result, const SlamConfig& config,
                           const OutputConfig& output, const std::filesystem::path& out_dir,
                           RunArtifacts* artifacts = nullptr);
RunSummary writeRunOutputs(const Sequence& sequence, const SlamResult& result,
                           const SlamConfig& config, const OutputConfig& output,
                           const std::filesystem::path& out_dir, RunArtifacts* artifacts = nullptr);

}  // namespace hazmap
