#include "hazmap/graph/optimizer.hpp"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <chrono>
#include <cstdio>
#include <memory>
#include <vector>

#include "graph/gravity_residual.hpp"
#include "graph/residuals.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/graph/chordal_init.hpp"
#include "hazmap/graph/gravity_prior.hpp"

namespace hazmap {

using namespace graph_detail;

PoseGraphInit parsePoseGraphInit(const std::string& name, const std::string& where) {
  if (name == "file" || name == "as-is" || name == "asis") return PoseGraphInit::AsIs;
  if (name == "odometry") return PoseGraphInit::Odometry;
  if (name == "chordal") return PoseGraphInit::Chordal;
  fail(where, "unknown initialisation '" + name + "' (expected file, odometry or chordal)");
}

LoopLoss parseLoopLoss(const std::string& name, const std::string& where) {
  if (name == "none") return LoopLoss::None;
  if (name == "cauchy") return LoopLoss::Cauchy;
  if (name == "dcs") return LoopLoss::Dcs;
  fail(where, "unknown loop loss '" + name + "' (expected none, cauchy or dcs)");
}

const char* toString(PoseGraphInit init) {
  switch (init) {
    case PoseGraphInit::Odometry: return "odometry";
    case PoseGraphInit::Chordal: return "chordal";
    default: return "file";
  }
}

const char* toString(LoopLoss loss) {
  switch (loss) {
    case LoopLoss::Cauchy: return "cauchy";
    case LoopLoss::Dcs: return "dcs";
    default: return "none";
  }
}

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

void checkConfig(const PoseGraphConfig& c) {
  const std::string where = "pose graph config";
  if (c.max_iterations < 0) fail(where, "max_iterations must be >= 0");
  if (c.threads < 1) fail(where, "threads must be >= 1");
  if (!(c.loop_loss_scale > 0.0)) fail(where, "loop_loss_scale must be > 0");
  if (!(c.function_tolerance >= 0.0) || !(c.gradient_tolerance >= 0.0) ||
      !(c.parameter_tolerance >= 0.0))
    fail(where, "tolerances must be >= 0");
}

ceres::LossFunction* makeLoss(const PoseGraphConfig& c, EdgeKind kind) {
  if (kind != EdgeKind::Loop) return nullptr;
  switch (c.loop_loss) {
    case LoopLoss::Cauchy: return new ceres::CauchyLoss(c.loop_loss_scale);
    case LoopLoss::Dcs: return new DcsLoss(c.loop_loss_scale * c.loop_loss_scale);
    default: return nullptr;
  }
}

/// Upper-triangular U with Ω = UᵀU (so ‖U e‖² = eᵀΩe).
template <typename M>
M sqrtInformation(const M& info) {
  Eigen::LLT<M> llt(info);
  if (llt.info() != Eigen::Success)
    fail("pose graph", "edge information is not positive definite");
  return llt.matrixU();
}

struct Solved {
  int iterations = 0;
  bool converged = false;
  std::string message;
  double cost = 0.0;  ///< Ceres' final cost (robust losses included)
};

/// One parameter block per node: x, y, yaw (2D) or translation + 3×3 rotation, column-major (3D).
std::vector<double> packPoses(const PoseGraph& graph, int block) {
  const int n = graph.numNodes();
  const bool planar = graph.dimension == 2;
  std::vector<double> params(static_cast<std::size_t>(n) * block);
  for (int i = 0; i < n; ++i) {
    double* p = params.data() + static_cast<std::size_t>(i) * block;
    const Eigen::Isometry3d& T = graph.poses[i];
    if (planar) {
      p[0] = T.translation().x();
      p[1] = T.translation().y();
      p[2] = yawOf(T);
    } else {
      Eigen::Map<Vec3>{p} = T.translation();
      Eigen::Map<Mat3>{p + 3} = T.linear();
    }
  }
  return params;
}

/// The residual of one edge for the configured cost (owned by the problem it is added to).
ceres::CostFunction* edgeCost(const PoseGraphEdge& e, int dimension, const PoseGraphConfig& config) {
  const bool planar = dimension == 2;
  const Matrix6d info = informationLeftToRight(e.T_from_to, e.information);
  if (config.cost == PoseGraphCost::Chordal) {
    const ChordalWeights w = chordalWeights(e, dimension);
    if (planar)
      return new ChordalCost2(e.T_from_to.translation().x(), e.T_from_to.translation().y(),
                              yawOf(e.T_from_to), w.kappa, w.tau);
    return new ChordalCost3(e.T_from_to.linear(), e.T_from_to.translation(), w.kappa, w.tau);
  }
  if (planar) {
    Eigen::Matrix3d info3;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) info3(r, c) = info(kPlanarIndex[r], kPlanarIndex[c]);
    return new GeodesicCost2(e.T_from_to.translation().x(), e.T_from_to.translation().y(),
                             yawOf(e.T_from_to), sqrtInformation(info3));
  }
  return new GeodesicCost3(e.T_from_to.linear(), e.T_from_to.translation(), sqrtInformation(info));
}

ceres::Solver::Options solverOptions(const PoseGraphConfig& config) {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.max_num_iterations = config.max_iterations;
  options.function_tolerance = config.function_tolerance;
  options.gradient_tolerance = config.gradient_tolerance;
  options.parameter_tolerance = config.parameter_tolerance;
  options.num_threads = config.threads;
  options.minimizer_progress_to_stdout = config.verbose;
  options.logging_type = config.verbose ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  return options;
}

/// Writes the optimised blocks back into graph.poses (the fixed node stays as it was).
void unpackPoses(const std::vector<double>& params, int block, PoseGraph& graph) {
  const bool planar = graph.dimension == 2;
  for (int i = 0; i < graph.numNodes(); ++i) {
    if (i == graph.fixed_node) continue;
    const double* p = params.data() + static_cast<std::size_t>(i) * block;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    if (planar) {
      T = fromXyYaw(p[0], p[1], wrapAngle(p[2]));
    } else {
      T.translation() = Eigen::Map<const Vec3>(p);
      T.linear() = Eigen::Map<const Mat3>(p + 3);
      T = normalized(T);
    }
    graph.poses[i] = T;
  }
}

Solved solve(PoseGraph& graph, const PoseGraphConfig& config) {
  const bool planar = graph.dimension == 2;
  const int block = planar ? 3 : 12;
  std::vector<double> params = packPoses(graph, block);
  const auto blockOf = [&](int node) { return params.data() + static_cast<std::size_t>(node) * block; };

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.enable_fast_removal = false;
  ceres::Problem problem(problem_options);
  PoseManifold3 manifold;   // outlives the problem's use of it (not owned)
  for (int i = 0; i < graph.numNodes(); ++i)
    problem.AddParameterBlock(blockOf(i), block, planar ? nullptr : &manifold);
  for (const auto& e : graph.edges)
    problem.AddResidualBlock(edgeCost(e, graph.dimension, config), makeLoss(config, e.kind), blockOf(e.from),
                             blockOf(e.to));
  problem.SetParameterBlockConstant(blockOf(graph.fixed_node));
  ceres::SphereManifold<3> sphere;  // world down: 2 degrees of freedom (not owned)
  Vec3 gravity_world = graph.gravity_world;
  if (!graph.gravity_priors.empty()) {
    problem.AddParameterBlock(gravity_world.data(), 3, &sphere);
    for (const auto& g : graph.gravity_priors)
      problem.AddResidualBlock(new GravityPriorCost(g.down, g.sigma), nullptr, blockOf(g.node), gravity_world.data());
  }

  ceres::Solver::Summary summary;
  ceres::Solve(solverOptions(config), &problem, &summary);
  if (config.verbose) std::fprintf(stderr, "%s\n", summary.FullReport().c_str());
  unpackPoses(params, block, graph);
  graph.gravity_world = gravity_world.normalized();
  Solved s;
  s.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  s.converged = summary.termination_type == ceres::CONVERGENCE;
  s.message = summary.message;
  s.cost = summary.final_cost;
  if (summary.termination_type == ceres::FAILURE)
    fail("pose graph optimisation", "Ceres failed: " + summary.message);
  return s;
}

}  // namespace

PoseGraphReport optimizePoseGraph(PoseGraph& graph, const PoseGraphConfig& config) {
  const auto start = Clock::now();
  checkConfig(config);
  checkOptimisable(graph, "pose graph optimisation");
  if (graph.dimension == 2)
    for (auto& T : graph.poses) T = planarized(T);
  PoseGraphReport report;
  switch (config.init) {
    case PoseGraphInit::Odometry: initialiseFromOdometry(graph); break;
    case PoseGraphInit::Chordal: chordalInitialisation(graph); break;
    default: break;
  }
  if (!graph.gravity_priors.empty()) {
    if (graph.dimension != 3) fail("pose graph optimisation", "gravity priors need a 3-D graph");
    graph.gravity_world = meanGravityWorld(graph);
  }
  report.init_seconds = secondsSince(start);
  report.initial_geodesic = geodesicCost(graph) + gravityPriorCost(graph);
  report.initial_chordal = chordalCost(graph) + gravityPriorCost(graph);
  const auto solve_start = Clock::now();
  if (!graph.edges.empty() && graph.numNodes() > 1) {
    const Solved s = solve(graph, config);
    report.iterations = s.iterations;
    report.converged = s.converged;
    report.message = s.message;
  } else {
    report.converged = true;
    report.message = "nothing to optimise";
  }
  report.solve_seconds = secondsSince(solve_start);
  report.final_geodesic = geodesicCost(graph) + gravityPriorCost(graph);
  report.final_chordal = chordalCost(graph) + gravityPriorCost(graph);
  report.total_seconds = secondsSince(start);
  return report;
}

}  // namespace hazmap
