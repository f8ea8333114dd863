#pragma once
// The pieces of `hazmap merge` (pipeline/merge_maps.hpp): the checked inputs, placing the maps in
// one graph, the merged folder's files and the map error.
#include <filesystem>
#include <vector>

#include "hazmap/graph/pose_graph.hpp"
#include "hazmap/map/map_folder.hpp"
#include "hazmap/pipeline/merge_maps.hpp"
#include "pipeline/prior_search.hpp"

namespace hazmap::pipeline_detail {

struct MergeInput {
  MapFolder map;
  FramePoses original;  ///< every frame's pose as the map has it (trajectory.kitti), its own frame
  FramePoses poses;     ///< the same once placed: in the merged frame
  PoseGraph graph;      ///< graph.g2o, one node per frame
};

/// Opens every map (openMap's checks), refuses the same folder twice, another class table than
/// the first map's, or a graph whose nodes are not the map's frames. One-line errors.
std::vector<MergeInput> openMergeInputs(const std::vector<std::filesystem::path>& maps);

/// The SLAM settings the first map was made with (map.json "parameters").
SlamConfig mergeConfig(const MapFolder& first, int threads);

/// Refuses an output folder that is one of the inputs, or exists and is not empty (without
/// `overwrite`, or when it is not a map folder). Returns whether an existing folder is replaced.
bool checkMergeOutput(const std::filesystem::path& out, const std::vector<std::filesystem::path>& maps,
                      bool overwrite);

/// Places inputs[1..] in inputs[0]'s frame one after another (each against every keyframe placed
/// before it), joins their graphs with the verified inter-session loops and solves. Fills
/// report.maps and the graph counts; a placed input's `poses` are then the merged ones.
PoseGraph placeMaps(std::vector<MergeInput>& inputs, const ClassTable& classes, const SlamConfig& config,
                    MergeReport& report);

/// Writes the merged map folder's files into `dir`: keyframes/, trajectory.kitti, graph.g2o, the
/// map of all keyframes (map.ply/.pcd, hazards.json/.csv, PNGs, viewer.html), changes.json/.csv
/// and, last, map.json.
/// `classes`: the first map's with the property classes its runs used (the search overview's).
void writeMergedFolder(const std::filesystem::path& dir, const std::vector<MergeInput>& inputs,
                       const PoseGraph& graph, const ClassTable& classes, const MergeOptions& options,
                       MergeReport& report);

/// The map error over the keyframes (first map alone, merged, each map in the merge) when every
/// placed map's sequence (map.json "source") has poses.txt; else report.map_error_note says why.
void measureMergeMapError(const std::vector<MergeInput>& inputs, MergeReport& report);

}  // namespace hazmap::pipeline_detail
