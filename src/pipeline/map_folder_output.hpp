#pragma once
// The reopenable map of a finished run (issue 34, part 1; hazmap/map/map_folder.hpp): during the
// map's second pass over the scans, each keyframe's scan (as tracking saw it) is written with
// its property landmarks; after run.json, map.json lands last.
#include <filesystem>
#include <string>
#include <vector>

#include "hazmap/map/map_folder.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "pipeline/prior_overview.hpp"

namespace hazmap::pipeline_detail {

/// The run's keyframes: the back end's rule (SlamConfig::keyframe_distance / keyframe_angle from
/// the last keyframe, the first frame first) over the tracked poses.
std::vector<std::size_t> keyframeFrames(const SlamResult& result, const SlamConfig& config);

class MapFolderOutput {
 public:
  /// Removes a previous map.json from `dir` (the folder is not a map until finish()).
  MapFolderOutput(std::filesystem::path dir, const SlamResult& result, const SlamConfig& config,
                  const ClassTable& classes);
  MapFolderOutput(const MapFolderOutput&) = delete;  // overview_ refers to search_classes_
  MapFolderOutput& operator=(const MapFolderOutput&) = delete;
  /// Frame `frame`'s scan, deskewed as tracking saw it: written when it is a keyframe.
  void addScan(std::size_t frame, const LabeledCloud& scan);
  /// map.json, listing the run's files (graph.g2o, trajectory.kitti, hazards.json; run.json is
  /// not listed: `hazmap run --camera` adds to it afterwards).
  void finish();

 private:
  std::filesystem::path dir_;
  const SlamResult& result_;
  const SlamConfig& config_;
  const ClassTable& classes_;
  std::vector<std::size_t> keyframes_;
  std::size_t next_ = 0;  // next keyframe expected
  MapManifest manifest_;
  std::vector<double> heights_;
  // The search overview (prior_overview.hpp), built from the keyframes as they are written: a
  // reader rebuilding it from their files gets the same bits (a written cloud reads back unchanged).
  ClassTable search_classes_;  ///< the run's classes with its property-ICP settings
  SearchOverviewBuilder overview_;
};

}  // namespace hazmap::pipeline_detail
