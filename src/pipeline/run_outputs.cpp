#include "hazmap/core/config_fields.hpp"
#include "hazmap/pipeline/run_outputs.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/graph/g2o.hpp"
#include "hazmap/map/export.hpp"
#include "hazmap/map/image.hpp"
#include "hazmap/map/map_folder.hpp"
#include "hazmap/map/outputs.hpp"
#include "pipeline/map_folder_output.hpp"

namespace hazmap {

namespace {

nlohmann::json statsJson(const DistanceStats& s) {
  return {{"count", s.count}, {"mean", s.mean}, {"median", s.median}, {"p95", s.p95},
          {"max", s.max}, {"rmse", s.rmse}};
}

// run.json "tracking": per-frame statuses, fallbacks and stalled frames.
nlohmann::json trackingJson(const SlamResult& r) {
  std::size_t fallbacks = 0;
  nlohmann::json fallback_frames = nlohmann::json::array();
  nlohmann::json relocalised_frames = nlohmann::json::array();
  nlohmann::json status = nlohmann::json::array();  // per frame: tracked / relocalised / fallback …
  nlohmann::json stalled = nlohmann::json::array();  // ICP stopped at its iteration limit (issue 14)
  double ms_sum = 0;
  for (const auto& f : r.frames) {
    ms_sum += f.milliseconds;
    if (f.stalled) stalled.push_back(f.index);
    status.push_back(toString(f.status));
    if (f.status == FrameStatus::Relocalised)
      relocalised_frames.push_back({{"frame", f.index}, {"reason", f.fallback_reason}});
    if (usesIcp(r.method) && f.index > 0 && !f.icp_used) {
      ++fallbacks;
      fallback_frames.push_back({{"frame", f.index}, {"reason", f.fallback_reason}});
    }
  }
  const TrackingCounts counts = countTracking(r.frames);
  return {{"mean_ms_per_frame", r.frames.empty() ? 0.0 : ms_sum / r.frames.size()},
                   {"odometry_fallbacks", fallbacks}, {"fallback_frames", fallback_frames},
                   {"tracked", counts.tracked}, {"relocalised", counts.relocalised},
                   {"flagged", counts.fallback}, {"relocalised_frames", relocalised_frames},
                   {"frame_status", status}, {"stalled_frames", stalled}};
}

// run.json "loop_closure": accepted loops and rejected candidates with their reasons.
nlohmann::json loopClosureJson(const SlamResult& r, const SlamConfig& config) {
  nlohmann::json loops = nlohmann::json::array();
  for (const auto& l : r.loops)
    loops.push_back({{"from", l.from_frame}, {"to", l.to_frame}, {"source", l.source},
                     {"fitness", l.fitness}, {"rmse", l.rmse}});
  nlohmann::json rejected = nlohmann::json::array();
  for (const auto& l : r.rejected_loops)
    rejected.push_back({{"from", l.from_frame}, {"to", l.to_frame}, {"reason", toString(l.reason)}, {"detail", l.detail}});
  nlohmann::json out = {{"enabled", usesPoseGraph(r.method)},
                        {"candidate_method", toString(config.loop_closure.method)},
                        {"keyframes", r.keyframes}, {"keyframes_searched", r.keyframes_searched},
                        {"candidates", r.loop_candidates},
                        {"verified", r.loops_verified},
                        {"accepted", r.loops.size()},
                        {"loops", loops},
                        {"rejected", rejected}};
  if (usesPoseGraph(r.method) && config.loop_closure.light_duplicate_keyframes > 0)
    out["light_verifications"] = r.loop_light_verifications;
  if (usesPoseGraph(r.method)) out["submap_targets_built"] = r.submap_targets_built;
  return out;
}

nlohmann::json runJson(const SlamResult& r, const SlamConfig& config, const RunSummary& summary) {
  nlohmann::json j;
  j["sequence"] = r.source;
  j["method"] = toString(r.method);
  j["frames"] = r.frames.size();
  j["frames_per_s"] = r.framesPerSecond();
  j["timings_s"] = {{"tracking", r.timings.tracking_s}, {"loop_closure", r.timings.loop_s},
                    {"pose_graph", r.timings.graph_s}, {"slam_total", r.timings.total_s},
                    {"outputs", summary.output_seconds}};
  j["tracking"] = trackingJson(r);
  j["loop_closure"] = loopClosureJson(r, config);
  nlohmann::json opt = nlohmann::json::array();
  for (std::size_t k = 0; k < r.optimisations.size(); ++k) {
    const auto& o = r.optimisations[k];
    nlohmann::json entry = {{"initial_geodesic", o.initial_geodesic}, {"final_geodesic", o.final_geodesic},
                            {"iterations", o.iterations}, {"seconds", o.total_seconds}};
    if (k < r.optimisation_outcomes.size()) {
      entry["applied"] = r.optimisation_outcomes[k].applied;
      if (!r.optimisation_outcomes[k].note.empty()) entry["note"] = r.optimisation_outcomes[k].note;
    }
    opt.push_back(entry);
  }
  j["pose_graph"] = {{"nodes", r.graph.numNodes()}, {"edges", r.graph.numEdges()},
                     {"loop_edges", r.graph.numLoopEdges()}, {"map_anchor_edges", r.anchors},
                     {"gravity_priors", r.graph.gravity_priors.size()},
                     {"optimisations", opt}};
  // Every setting of the run, nested as in the YAML (`hazmap run --config` reads it back).
  j["parameters"] = configToJson(config);
  j["map"] = {{"cells", summary.map_cells}, {"memory_bytes", summary.map_memory_bytes},
              {"hazards", summary.hazards}};
  if (summary.map_error) {
    const auto& m = *summary.map_error;
    j["map_error"] = {{"point", statsJson(m.point)}, {"c2c", statsJson(m.c2c)},
                      {"c2c_reverse", statsJson(m.c2c_reverse)}};
  }
  if (summary.trajectory) j["trajectory_eval"] = nlohmann::json::parse(toJson(*summary.trajectory));
  if (summary.edge_nees) j["edge_nees"] = nlohmann::json::parse(toJson(*summary.edge_nees));
  return j;
}


/// The scans once more, as tracking saw them (deskewed), placed with the final poses: the map,
/// and the paper's map error (Table 2) when every scan has a ground-truth pose.
Trajectory assembleMap(ScanSource& scans, const SlamResult& result, GlobalMap& map,
                       const MapErrorConfig& error_config, std::optional<MapErrorResult>& map_error,
                       const std::string& where, pipeline_detail::MapFolderOutput* folder) {
  const std::size_t n = result.estimate.size();
  std::optional<MapErrorAccumulator> error;
  Trajectory truth;
  std::size_t i = 0;
  for (std::optional<Scan> scan; (scan = scans.next()); ++i) {
    if (i >= n) break;
    redoDeskew(scan->cloud, result.frames.at(i));
    map.insert(i, scan->cloud, result.estimate.poses[i], scan->channels);
    if (folder) folder->addScan(i, scan->cloud);
    if (i == 0 && scan->ground_truth) error.emplace(error_config);
    if (!scan->ground_truth) error.reset();
    if (!error) continue;
    error->addFrame(scan->cloud, result.estimate.poses[i], *scan->ground_truth);
    truth.push_back(result.estimate.stamps[i], *scan->ground_truth);
  }
  if (i != n)
    fail(where, "the second pass over " + scans.describe() + " gave " + std::to_string(i) +
                    " scans, the run had " + std::to_string(n));
  if (!error) return {};
  map_error = error->result();
  return truth;
}

}  // namespace

std::string formatRunSummary(const SlamResult& result, const RunSummary& summary,
                             const std::filesystem::path& out_dir, const OutputConfig& output) {
  std::string s = fmt::format("\n{}: {} frames at {:.1f} frames/s, {} loop{} closed, {} hazard{} found, map of {} cells.\n",
                              toString(result.method), result.frames.size(), result.framesPerSecond(),
                              result.loops.size(), result.loops.size() == 1 ? "" : "s", summary.hazards,
                              summary.hazards == 1 ? "" : "s", summary.map_cells);
  if (usesIcp(result.method)) {
    const TrackingCounts c = countTracking(result.frames);
    s += fmt::format("Tracking: {} frames tracked, {} relocalised by global registration, {} flagged (fallback to "
                     "the guess; see run.json).\n", c.tracked, c.relocalised, c.fallback);
  }
  if (summary.map_error)
    s += fmt::format("Map error against the map from the true poses: mean {:.3f} m, median {:.3f} m, p95 {:.3f} m.\n",
                     summary.map_error->point.mean, summary.map_error->point.median, summary.map_error->point.p95);
  if (summary.trajectory)
    s += fmt::format("Trajectory error (ATE, SE(3)-aligned): rmse {:.3f} m over {:.0f} m.\n",
                     summary.trajectory->ape.translation.rmse, summary.trajectory->gt_length_m);
  const std::string dir = out_dir.string() + (out_dir.string().ends_with('/') ? "" : "/");
  s += "Files in " + dir + ":\n";
  if (output.write_viewer) s += "  viewer.html             the map in 3D with its hazards: open it in a browser\n";
  if (output.write_pngs) s += "  map_top.png             top-down map, hazards ringed and numbered\n"
                              "  trajectory.png          the trajectory (and its error when the truth is known)\n";
  s += "  hazards.json, .csv      the hazard list (class, position, size, frames that saw it)\n"
       "  map.ply, map.pcd        the map (CloudCompare, PCL)\n"
       "  trajectory.kitti, .tum, graph.g2o, run.json\n";
  return s;
}

RunSummary writeRunOutputs(const Sequence& sequence, const SlamResult& result, const SlamConfig& config,
                           const OutputConfig& output, const std::filesystem::path& out_dir,
                           RunArtifacts* artifacts) {
  const auto scans = sequenceScanSource(sequence);
  return writeRunOutputs(*scans, result, config, output, out_dir, artifacts);
}

namespace {

/// Everything but the map: trajectories, graph, the map's files, run.json (the map folder last).
RunSummary writeFiles(const GlobalMap& map, const SlamResult& result, const SlamConfig& config,
                      const OutputConfig& output, const std::filesystem::path& out_dir, const Trajectory* truth,
                      pipeline_detail::MapFolderOutput* folder, RunSummary summary,
                      std::chrono::steady_clock::time_point t0, RunArtifacts* artifacts) {
  const std::size_t n = result.estimate.size();
  writeKittiTrajectory(out_dir / "trajectory.kitti", result.estimate);
  writeTumTrajectory(out_dir / "trajectory.tum", result.estimate);
  if (!result.odometry_only.empty())
    writeKittiTrajectory(out_dir / "odometry_only.kitti", result.odometry_only);
  writeG2o(out_dir / "graph.g2o", result.graph);
  // The map's files (map.ply/.pcd, hazards, map_top.png, trajectory.png): the map stage's job.
  MapOutputConfig files;
  files.hazards = output.hazards;
  files.top_down = output.top_down;
  files.write_pngs = output.write_pngs;
  files.write_viewer = output.write_viewer;
  files.channel_cameras = output.channel_cameras;
  if (output.render_clip_above_sensor > 0 && !files.top_down.clip_above) {
    double z = 0;
    for (const auto& p : result.estimate.poses) z += p.translation().z();
    files.top_down.clip_above = z / static_cast<double>(n) + output.render_clip_above_sensor;
  }
  if (files.top_down.title.empty()) files.top_down.title = std::string("hazmap ") + toString(result.method);
  files.plot.title = std::string("Trajectory: ") + toString(result.method);
  MapOutputs written =
      writeMapOutputs(out_dir, map, result.estimate, truth,
                      result.odometry_only.empty() ? nullptr : &result.odometry_only, files);
  summary.map_cells = map.size();
  summary.map_memory_bytes = map.memoryBytes();
  summary.hazards = written.hazards.size();
  summary.output_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  writeTextAtomically(out_dir / "run.json", runJson(result, config, summary).dump(2) + "\n");
  if (folder) folder->finish();
  if (artifacts) {
    artifacts->map = std::move(written.cloud);
    artifacts->hazards = std::move(written.hazards);
  }
  return summary;
}

void createOutputFolder(const std::filesystem::path& out_dir) {
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) fail(out_dir.string(), "cannot create output folder: " + ec.message());
}

}  // namespace

RunSummary writeRunOutputs(ScanSource& scans, const SlamResult& result, const SlamConfig& config,
                           const OutputConfig& output, const std::filesystem::path& out_dir,
                           RunArtifacts* artifacts) {
  const auto t0 = std::chrono::steady_clock::now();
  createOutputFolder(out_dir);
  const std::size_t n = result.estimate.size();
  if (scans.size() && *scans.size() != n)
    fail(out_dir.string(), "result does not match the sequence's frame count");

  RunSummary summary;
  summary.frames = n;
  GlobalMap map(output.map, scans.classTable());
  // The outputs change: a previous map.json no longer describes them (MapFolderOutput writes anew).
  invalidateMapFolder(out_dir);
  std::optional<pipeline_detail::MapFolderOutput> folder;
  if (output.write_map_folder) folder.emplace(out_dir, result, config, scans.classTable());
  const Trajectory truth_poses = assembleMap(scans, result, map, output.map_error, summary.map_error,
                                             out_dir.string(), folder ? &*folder : nullptr);
  const bool with_truth = truth_poses.size() == n;
  const Trajectory* truth = with_truth ? &truth_poses : nullptr;
  if (with_truth) {
    // SE(3)-aligned APE as evo reports it; a straight-line run (a corridor) cannot be aligned
    // rotationally, and then — estimate and truth share the start pose — no alignment is used.
    try {
      summary.trajectory = evaluateTrajectory(*truth, result.estimate);
    } catch (const Error&) {
      TrajectoryEvalConfig unaligned;
      unaligned.ape_alignment = Alignment::None;
      summary.trajectory = evaluateTrajectory(*truth, result.estimate, unaligned);
    }
    // How honest the edges' information is (NEES against the true relative poses).
    if (result.graph.numNodes() == static_cast<int>(n))
      summary.edge_nees = computeEdgeNees(result.graph, truth_poses.poses, out_dir.string());
  }
  return writeFiles(map, result, config, output, out_dir, truth, folder ? &*folder : nullptr, std::move(summary), t0,
                    artifacts);
}

RunSummary writeRunOutputs(const GlobalMap& map, const SlamResult& result, const SlamConfig& config,
                           const OutputConfig& output, const std::filesystem::path& out_dir,
                           RunArtifacts* artifacts) {
  const auto t0 = std::chrono::steady_clock::now();
  createOutputFolder(out_dir);
  const std::size_t n = result.estimate.size();
  if (map.frames() != n)
    fail(out_dir.string(), "the map holds " + std::to_string(map.frames()) + " frames, the run " + std::to_string(n));
  if (output.write_map_folder) fail(out_dir.string(), "the map folder needs the scans (a second pass)");
  RunSummary summary;
  summary.frames = n;
  invalidateMapFolder(out_dir);
  return writeFiles(map, result, config, output, out_dir, nullptr, nullptr, std::move(summary), t0, artifacts);
}

}  // namespace hazmap
