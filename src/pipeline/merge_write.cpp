// The merged map folder (pipeline/merge_detail.hpp): every placed map's keyframes renumbered into
// the merged frames, one map of all of them at the merged poses with its hazards, what changed
// from the first mission to each later one, and map.json last.
#include <fmt/format.h>

#include "hazmap/graph/g2o.hpp"
#include "hazmap/map/hazard_changes.hpp"
#include "hazmap/map/outputs.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "pipeline/merge_detail.hpp"
#include "pipeline/prior_overview.hpp"

namespace hazmap::pipeline_detail {

namespace fs = std::filesystem;

namespace {

// One mission's keyframes at the merged poses: its own map (frames numbered as in the mission),
// for the hazards it saw and the surfaces it looked at.
struct MissionMap {
  int mission = 0;  ///< 1-based input number
  std::vector<Hazard> hazards;
  LabeledCloud cloud;
};

// Copies input `in`'s keyframes into `dir` and inserts them into `merged` and its own map.
MissionMap addKeyframes(const fs::path& dir, const MergeInput& in, std::size_t offset, const PoseGraph& graph,
                        GlobalMap& merged, const OutputConfig& outputs, MapManifest& manifest) {
  GlobalMap own(outputs.map, in.map.classes());
  for (std::size_t k = 0; k < in.map.keyframes().size(); ++k) {
    const MapKeyframe& kf = in.map.keyframes()[k];
    const LabeledCloud cloud = in.map.loadKeyframe(k);
    MapKeyframe out = kf;
    out.frame = offset + kf.frame;
    out.pose = graph.poses.at(out.frame);
    out.cloud = copyMapKeyframeCloud(dir, out.frame, in.map.dir() / kf.cloud);
    merged.insert(out.frame, cloud, out.pose);
    own.insert(kf.frame, cloud, out.pose);
    manifest.keyframes.push_back(std::move(out));
  }
  return {0, findHazards(own, outputs.hazards), own.cloud()};
}

MapOutputConfig mapFiles(const OutputConfig& outputs, const MergeOptions& options, const Trajectory& trajectory) {
  MapOutputConfig files;
  files.hazards = outputs.hazards;
  files.top_down = outputs.top_down;
  files.write_pngs = options.write_pngs;
  files.write_viewer = options.write_viewer;
  double z = 0;
  for (const auto& p : trajectory.poses) z += p.translation().z();
  files.top_down.clip_above = z / static_cast<double>(trajectory.size()) + outputs.render_clip_above_sensor;
  files.top_down.title = "hazmap merge";
  files.plot.title = "Trajectories of the merged missions";
  return files;
}

}  // namespace

void writeMergedFolder(const fs::path& dir, const std::vector<MergeInput>& inputs, const PoseGraph& graph,
                       const ClassTable& classes, const MergeOptions& options, MergeReport& report) {
  const MapFolder& first = inputs[0].map;
  const OutputConfig outputs;
  MapManifest manifest;
  manifest.method = first.manifest().method;
  manifest.frames = static_cast<std::size_t>(graph.numNodes());
  manifest.sensor_height = first.manifest().sensor_height;
  manifest.parameters_json = first.manifest().parameters_json;
  GlobalMap merged(outputs.map, first.classes());
  std::vector<MissionMap> missions;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    if (!report.maps[i].placed) continue;
    manifest.source += (manifest.source.empty() ? "merge of " : " + ") + inputs[i].map.dir().string();
    missions.push_back(addKeyframes(dir, inputs[i], report.maps[i].node_offset, graph, merged, outputs, manifest));
    missions.back().mission = static_cast<int>(i + 1);
  }
  Trajectory trajectory;
  for (int n = 0; n < graph.numNodes(); ++n) trajectory.push_back(n, graph.poses[static_cast<std::size_t>(n)]);
  writeKittiTrajectory(dir / "trajectory.kitti", trajectory);
  writeG2o(dir / "graph.g2o", graph);
  // Each later mission against the first (both at the merged poses).
  std::vector<HazardChange> changes;
  for (std::size_t m = 1; m < missions.size(); ++m)
    for (auto& c : compareHazards(missions[0].hazards, missions[m].hazards, missions[m].cloud)) {
      c.mission = missions[m].mission;
      report.changes += c.changed();
      changes.push_back(std::move(c));
    }
  writeHazardChanges(dir, changes);
  MapOutputConfig files = mapFiles(outputs, options, trajectory);
  files.changes = std::move(changes);  // the viewer's changes layer and table
  const MapOutputs written = writeMapOutputs(dir, merged, trajectory, nullptr, nullptr, files);
  report.hazards = written.hazards.size();
  const std::string extras = writeGraphExtras(dir, graph);
  manifest.search_overview = writeSearchOverview(dir, manifest, first.classes(), classes);
  writeMapManifest(dir, manifest, first.classes(), {"graph.g2o", "trajectory.kitti", "hazards.json"}, extras);
}

}  // namespace hazmap::pipeline_detail
