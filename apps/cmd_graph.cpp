// `hazmap graph optimize IN.g2o --out OUT.g2o [--cost chordal|geodesic] [--init ...]`
#include <fmt/format.h>

#include <memory>

#include "command.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/graph/optimizer.hpp"
#include "hazmap/io/g2o.hpp"

namespace hazmap::cli {
namespace {

struct GraphOptimizeArgs {
  std::string input;
  std::string output;
  std::string config_file;
  std::string cost = "geodesic";
  std::string init = "auto";
  std::string loop_loss = "none";
  double loop_loss_scale = 3.0;
  int max_iterations = 100;
  int threads = 1;
  bool verbose = false;
  bool strict = false;
};

// Indefinite information matrices (benchmark files such as cubicle.g2o): the chordal cost reads
// only the diagonal blocks, as SE-Sync does; the geodesic cost needs the whole matrix and gets
// the nearest positive-definite one; --strict refuses. One line on stderr says what was done.
G2oInformation informationPolicy(const GraphOptimizeArgs& a, PoseGraphCost cost) {
  if (a.strict) return G2oInformation::Strict;
  return cost == PoseGraphCost::Chordal ? G2oInformation::DiagonalBlocks : G2oInformation::NearestPositiveDefinite;
}

void reportAdjusted(const std::string& file, const G2oReadInfo& info, G2oInformation policy) {
  if (info.adjusted_lines.empty()) return;
  const std::size_t n = info.adjusted_lines.size();
  const std::string others = n > 1 ? fmt::format(" (and {} more edge{})", n - 1, n > 2 ? "s" : "") : "";
  if (policy == G2oInformation::DiagonalBlocks)
    fmt::print(stderr, "note: {}:{}: information matrix is not positive definite; the chordal cost uses its "
               "translation and rotation blocks only, as SE-Sync does{}\n", file, info.adjusted_lines.front(), others);
  else
    fmt::print(stderr, "warning: {}:{}: information matrix is not positive definite; projected to the nearest "
               "positive-definite matrix{} (--strict refuses)\n", file, info.adjusted_lines.front(), others);
}

void runOptimize(const GraphOptimizeArgs& a, const CLI::App& sub) {
  PoseGraphConfig config = a.config_file.empty() ? PoseGraphConfig{}
                                                 : loadPoseGraphConfig(a.config_file);
  // Files are benchmark or exported graphs: no robust loss unless asked for (it would change
  // the optimum compared with published values).
  if (a.config_file.empty() || sub.count("--loop-loss")) config.loop_loss = parseLoopLoss(a.loop_loss, "--loop-loss");
  if (a.config_file.empty() || sub.count("--cost")) config.cost = parsePoseGraphCost(a.cost, "--cost");
  if (a.config_file.empty() || sub.count("--loop-loss-scale")) config.loop_loss_scale = a.loop_loss_scale;
  if (a.config_file.empty() || sub.count("--max-iterations")) config.max_iterations = a.max_iterations;
  if (a.config_file.empty() || sub.count("--threads")) config.threads = a.threads;
  if (a.verbose) config.verbose = true;

  G2oReadInfo info;
  const G2oInformation policy = informationPolicy(a, config.cost);
  PoseGraph graph = readG2o(a.input, &info, policy);
  reportAdjusted(a.input, info, policy);
  if (a.config_file.empty() || sub.count("--init")) {
    // auto: files without vertex lines only have composed odometry, start from the chordal
    // solution; otherwise from the file's vertices.
    config.init = a.init != "auto" ? parsePoseGraphInit(a.init, "--init")
                  : info.had_vertices ? PoseGraphInit::AsIs
                                      : PoseGraphInit::Chordal;
  }
  checkOptimisable(graph, a.input);

  fmt::print("graph: {} ({}-D, {} nodes, {} edges of which {} loop{})\n", a.input,
             graph.dimension, graph.numNodes(), graph.numEdges(), graph.numLoopEdges(),
             info.had_vertices ? "" : "; no vertex lines, poses composed from odometry");
  fmt::print("cost: {}, init: {}, loop loss: {}, threads: {}\n", toString(config.cost),
             toString(config.init), toString(config.loop_loss), config.threads);
  const PoseGraphReport r = optimizePoseGraph(graph, config);
  fmt::print("{:<10} {:>16} {:>16}\n", "cost", "initial", "final");
  fmt::print("{:<10} {:>16.8g} {:>16.8g}   (SE-Sync F, no 1/2)\n", "chordal", r.initial_chordal,
             r.final_chordal);
  fmt::print("{:<10} {:>16.8g} {:>16.8g}   (chi2, no 1/2)\n", "geodesic", r.initial_geodesic,
             r.final_geodesic);
  fmt::print("iterations: {}, init {:.3f} s, solve {:.3f} s, total {:.3f} s, {}\n", r.iterations,
             r.init_seconds, r.solve_seconds, r.total_seconds,
             r.converged ? "converged" : "NOT converged: " + r.message);
  if (!a.output.empty()) {
    writeG2o(a.output, graph);
    fmt::print("wrote {}\n", a.output);
  }
}

const RegisterCommand registration{Command{
    "graph", "Pose-graph tools (optimise g2o files with the chordal or geodesic cost)",
    [](CLI::App& app) {
      app.require_subcommand(1);
      auto args = std::make_shared<GraphOptimizeArgs>();
      CLI::App* opt = app.add_subcommand(
          "optimize", "Optimise a g2o pose graph; prints initial/final cost in both conventions");
      opt->add_option("input", args->input, "input g2o file (VERTEX_SE3:QUAT/EDGE_SE3:QUAT or "
                                            "VERTEX_SE2/EDGE_SE2)")
          ->required();
      opt->add_option("--out,-o", args->output, "write the optimised graph here (g2o)");
      opt->add_option("--config", args->config_file,
                      "YAML file with a graph: section (flags given override it)");
      opt->add_option("--cost", args->cost, "geodesic (g2o/GTSAM chi2) or chordal (SE-Sync F)")
          ->check(CLI::IsMember({"geodesic", "chordal"}));
      opt->add_option("--init", args->init,
                      "auto (file if it has vertices, else chordal), file, odometry or chordal")
          ->check(CLI::IsMember({"auto", "file", "odometry", "chordal"}));
      opt->add_option("--loop-loss", args->loop_loss, "robust loss on loop edges: none, cauchy, dcs")
          ->check(CLI::IsMember({"none", "cauchy", "dcs"}));
      opt->add_option("--loop-loss-scale", args->loop_loss_scale,
                      "loss scale c (whitened residual units)");
      opt->add_option("--max-iterations", args->max_iterations, "Levenberg-Marquardt iterations");
      opt->add_option("--threads", args->threads, "threads for Jacobian evaluation");
      opt->add_flag("--verbose,-v", args->verbose, "print Ceres progress");
      opt->add_flag("--strict", args->strict,
                    "refuse information matrices that are not positive definite (default: chordal "
                    "uses their diagonal blocks, geodesic the nearest positive-definite matrix)");
      opt->callback([args, opt] { runOptimize(*args, *opt); });
    }}};

}  // namespace
}  // namespace hazmap::cli
