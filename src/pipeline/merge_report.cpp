// What `hazmap merge` measures and reports (pipeline/merge_maps.hpp): the map error over the
// keyframes when the missions' truth is known, merge.json and the summary.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "hazmap/io/trajectory.hpp"
#include "map/map_folder_json.hpp"
#include "pipeline/merge_detail.hpp"

namespace hazmap {

namespace fs = std::filesystem;

namespace pipeline_detail {

namespace {

// The truth of input `in` (its sequence's poses.txt, one pose per frame), or why not.
std::optional<Trajectory> truthOf(const MergeInput& in, std::string& note) {
  const fs::path path = fs::path(in.map.manifest().source) / "poses.txt";
  std::error_code ec;
  if (in.map.manifest().source.empty() || !fs::is_regular_file(path, ec)) {
    note = in.map.dir().string() + ": its sequence has no poses.txt (" + path.string() + ")";
    return std::nullopt;
  }
  Trajectory t = readKittiTrajectory(path);
  if (t.size() != in.poses.size()) {
    note = fmt::format("{}: {} poses for {} frames", path.string(), t.size(), in.poses.size());
    return std::nullopt;
  }
  return t;
}

}  // namespace

void measureMergeMapError(const std::vector<MergeInput>& inputs, MergeReport& report) {
  std::vector<std::optional<Trajectory>> truth;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    truth.emplace_back();
    if (report.maps[i].placed && !(truth.back() = truthOf(inputs[i], report.map_error_note))) return;
  }
  const MapErrorConfig config;  // as `hazmap run` measures it
  MapErrorAccumulator alone(config), merged(config);
  std::vector<std::pair<std::size_t, MapErrorAccumulator>> each;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    if (!report.maps[i].placed) continue;
    each.emplace_back(i, MapErrorAccumulator(config));
    const MapFolder& map = inputs[i].map;
    for (std::size_t k = 0; k < map.keyframes().size(); ++k) {
      const std::size_t f = map.keyframes()[k].frame;
      const LabeledCloud cloud = map.loadKeyframe(k);
      const Eigen::Isometry3d& T_true = truth[i]->poses.at(f);
      if (i == 0) alone.addFrame(cloud, inputs[i].original.at(f), T_true);
      merged.addFrame(cloud, inputs[i].poses.at(f), T_true);
      each.back().second.addFrame(cloud, inputs[i].poses.at(f), T_true);
    }
  }
  report.map_errors.push_back({"first map alone", alone.result()});
  report.map_errors.push_back({"merged", merged.result()});
  for (const auto& [i, acc] : each) report.map_errors.push_back({fmt::format("map {} in the merge", i + 1), acc.result()});
}

}  // namespace pipeline_detail

namespace {

nlohmann::json attemptsJson(const std::vector<PriorAttempt>& list) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& x : list)
    a.push_back({{"frame", x.frame}, {"accepted", x.accepted}, {"merged_frame", x.prior_keyframe},
                 {"outcome", x.outcome}, {"pose", map_folder_detail::poseJson(x.pose)}});
  return a;
}

nlohmann::json placementJson(const MapPlacement& p, std::size_t index) {
  const PriorLocalisation& l = p.localisation;
  nlohmann::json j = {{"map", p.dir.string()}, {"placed", p.placed}, {"frames", p.frames}, {"keyframes", p.keyframes}};
  if (p.placed) j["node_offset"] = p.node_offset;
  if (index == 0) return j;
  j["state"] = toString(l.state);
  if (l.state == PriorState::Localised) j["localised_at_frame"] = l.frame;
  j["inter_session_loops"] = p.inter_session_loops;
  j["search"] = attemptsJson(l.search);
  j["loops"] = attemptsJson(l.loops);
  j["seconds_per_attempt"] = l.seconds_per_attempt;
  j["seconds"] = l.total_seconds;
  if (!l.optimisation_note.empty()) j["note"] = l.optimisation_note;
  return j;
}

}  // namespace

std::string mergeJson(const MergeReport& r) {
  nlohmann::json maps = nlohmann::json::array();
  for (std::size_t i = 0; i < r.maps.size(); ++i) maps.push_back(placementJson(r.maps[i], i));
  nlohmann::json errors = nlohmann::json::array();
  for (const auto& e : r.map_errors)
    errors.push_back({{"what", e.what}, {"keyframes", e.error.frames}, {"mean", e.error.point.mean},
                      {"median", e.error.point.median}, {"p95", e.error.point.p95}});
  nlohmann::json j = {{"maps", maps},
                      {"pose_graph", {{"nodes", r.nodes}, {"edges", r.edges}, {"inter_session_loops", r.inter_session_loops},
                                      {"loops_disagreeing_after_solve", r.loops_disagreeing},
                                      {"optimisation_failures", r.optimisation_notes}}},
                      {"map_error", errors},
                      {"hazards", r.hazards},
                      {"changes", r.changes},
                      {"seconds", r.seconds}};
  if (!r.map_error_note.empty()) j["map_error_note"] = r.map_error_note;
  return j.dump(2) + "\n";
}

std::string formatMergeSummary(const MergeReport& r, const fs::path& out) {
  std::size_t placed = 0;
  for (const auto& m : r.maps) placed += m.placed;
  std::string s = fmt::format("\nmerge: {} of {} maps placed; one graph of {} nodes, {} edges, {} inter-session loops "
                              "(each verified by property ICP; {} disagree after the solve).\n",
                              placed, r.maps.size(), r.nodes, r.edges, r.inter_session_loops, r.loops_disagreeing);
  for (std::size_t i = 1; i < r.maps.size(); ++i) {
    const MapPlacement& m = r.maps[i];
    s += m.placed ? fmt::format("  {}: placed (localised at its frame {}, {} loops)\n", m.dir.string(),
                                m.localisation.frame, m.inter_session_loops)
                  : fmt::format("  {}: NOT placed ({}), left out\n", m.dir.string(),
                                m.localisation.optimisation_note.empty() ? "never localised" : m.localisation.optimisation_note);
  }
  for (const auto& e : r.map_errors)
    s += fmt::format("Map error, {}: mean {:.4f} m over {} keyframes.\n", e.what, e.error.point.mean, e.error.frames);
  s += fmt::format("{} hazards in the merged map; {} changes from the first mission (changes.json, changes.csv).\n",
                   r.hazards, r.changes);
  s += "Files in " + out.string() + ": map.json (a map folder: use it as --prior or merge it again), merge.json, "
       "map.ply, hazards.json, viewer.html.\n";
  return s;
}

}  // namespace hazmap
