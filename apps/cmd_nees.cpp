// hazmap nees: how honest a run's pose-graph edge information is — NEES of every odometry and
// loop edge against the true relative poses (eval/edge_nees.hpp).
#include <filesystem>
#include <iostream>
#include <memory>
#include <vector>
#include <nlohmann/json.hpp>

#include "command.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/eval/edge_nees.hpp"
#include "hazmap/eval/trajectory_metrics.hpp"
#include "hazmap/graph/g2o.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/trajectory.hpp"

namespace hazmap::cli {
namespace {

namespace fs = std::filesystem;

struct NeesOptions {
  std::string run;    ///< a `hazmap run` output folder (graph.g2o, run.json)
  std::string graph;  ///< or a g2o file
  std::string gt;     ///< true poses, one per node (KITTI or TUM)
  bool json = false;
  bool edges = false;
  std::vector<int> spans;  ///< odometry-chain spans (frames) whose NEES to report as well
};

// The ground truth of a run folder: --gt, else poses.txt of the sequence run.json names.
fs::path truthPath(const NeesOptions& o) {
  if (!o.gt.empty()) return o.gt;
  if (o.run.empty()) fail("--gt", "is needed with --graph (the true poses, one per node)");
  const fs::path run_json = fs::path(o.run) / "run.json";
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(readTextFile(run_json));
  } catch (const nlohmann::json::exception& e) {
    fail(run_json.string(), std::string("is not valid JSON: ") + e.what());
  }
  if (!j.contains("sequence") || !j["sequence"].is_string())
    fail(run_json.string(), "names no sequence; pass --gt");
  const fs::path poses = fs::path(j["sequence"].get<std::string>()) / "poses.txt";
  if (!fs::exists(poses)) fail(poses.string(), "does not exist (the run's input has no ground truth); pass --gt");
  return poses;
}

void run(const NeesOptions& o) {
  if (o.run.empty() == o.graph.empty()) fail("nees", "give exactly one of RUN_DIR or --graph FILE");
  const fs::path graph_path = o.run.empty() ? fs::path(o.graph) : fs::path(o.run) / "graph.g2o";
  if (!fs::exists(graph_path)) fail(graph_path.string(), "does not exist");
  const PoseGraph graph = readG2o(graph_path);
  const fs::path gt_path = truthPath(o);
  const Trajectory truth = readTrajectoryAuto(gt_path);
  checkTrajectory(truth, gt_path.string());
  const EdgeNeesReport report = computeEdgeNees(graph, truth.poses, graph_path.string() + " vs " + gt_path.string());
  if (o.json) {
    nlohmann::json j = nlohmann::json::parse(toJson(report, o.edges));
    for (int k : o.spans) j["odometry_span"][std::to_string(k)] = nlohmann::json::parse(toJson(odometrySpanNees(graph, truth.poses, k)));
    std::cout << j.dump(2) << "\n";
    return;
  }
  std::cout << graph_path.string() << ": " << graph.numEdges() << " edges, truth " << gt_path.string() << "\n"
            << toText(report);
  for (int k : o.spans) {
    const NeesStats s = odometrySpanNees(graph, truth.poses, k);
    std::cout << "odometry spans of " << k << " frames: " << s.count << ", NEES mean " << s.mean << ", median " << s.median << "\n";
  }
}

const RegisterCommand kRegister{{
    "nees",
    "Edge NEES of a run's pose graph against the true poses: are the odometry and loop edges' "
    "covariances honest (mean 6)?",
    [](CLI::App& app) {
      auto o = std::make_shared<NeesOptions>();
      app.add_option("run", o->run, "A `hazmap run` output folder (reads graph.g2o; truth from run.json's sequence)");
      app.add_option("--graph", o->graph, "A g2o graph instead of a run folder (needs --gt)");
      app.add_option("--gt", o->gt, "True poses, one per graph node (KITTI or TUM)")->check(CLI::ExistingFile);
      app.add_flag("--json", o->json, "Print JSON (summaries per edge type)");
      app.add_flag("--edges", o->edges, "With --json: also every edge's error vector and NEES");
      app.add_option("--span", o->spans, "Also the NEES of the odometry chain over spans of K frames (repeatable)")
          ->check(CLI::PositiveNumber);
      app.callback([o] { run(*o); });
    },
}};

}  // namespace
}  // namespace hazmap::cli
