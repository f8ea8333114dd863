#pragma once
// Pose-graph optimiser on Ceres (paper section V, eq. 3): minimises the geodesic or the chordal
// cost (graph/costs.hpp) over all poses but the fixed one, with Levenberg–Marquardt and sparse
// normal Cholesky (SuiteSparse). Poses live on SO(3)×R³ (SO(2)×R² for 2-D graphs) with analytic
// Jacobians. Loop edges can get a robust loss (Cauchy or DCS), odometry edges never do.
//
// Typical use in the SLAM pipeline:
//   PoseGraph g;                              // g.dimension = 3
//   g.addNode(T_world_0); g.addNode(T_world_1); ...
//   g.addEdge(0, 1, T_0_1, odom_information);                      // EdgeKind::Odometry
//   g.addEdge(7, 42, icp.transform, icp.covariance.inverse(), EdgeKind::Loop);
//   PoseGraphReport r = optimizePoseGraph(g);  // g.poses now hold the optimised poses
#include <filesystem>
#include <string>
#include <vector>

#include "hazmap/core/config_fwd.hpp"
#include "hazmap/graph/costs.hpp"
#include "hazmap/graph/pose_graph.hpp"

namespace hazmap {

/// Where the optimisation starts from.
enum class PoseGraphInit {
  AsIs,      ///< the poses already in the graph ("file" on the CLI)
  Odometry,  ///< compose odometry edges from the fixed node (initialiseFromOdometry)
  Chordal,   ///< rotations by linear least squares + projection, then translations (chordal_init)
};

/// Robust loss on loop edges (in units of the whitened squared residual s = cost of the edge).
enum class LoopLoss {
  None,
  Cauchy,  ///< ρ(s) = c² log(1 + s / c²)
  Dcs,     ///< dynamic covariance scaling: ρ(s) = s for s ≤ Φ, Φ(3s − Φ)/(s + Φ) beyond (Φ = c²)
};

PoseGraphInit parsePoseGraphInit(const std::string& name, const std::string& where = "init");
LoopLoss parseLoopLoss(const std::string& name, const std::string& where = "loop_loss");
const char* toString(PoseGraphInit init);
const char* toString(LoopLoss loss);

struct PoseGraphConfig {
  PoseGraphCost cost = PoseGraphCost::Geodesic;  ///< geodesic for SLAM; chordal to compare with F*
  PoseGraphInit init = PoseGraphInit::AsIs;      ///< start from the poses in the graph
  LoopLoss loop_loss = LoopLoss::Cauchy;         ///< robust loss on loop edges only
  /// Loss scale c (in whitened units): a loop edge whose squared whitened error s exceeds c² is
  /// progressively down-weighted (Cauchy weight 1/(1 + s/c²)). With c = 3, s = 9 (a 3σ-ish error of
  /// a 6-D edge) gets weight ½; a wrong loop with s ~ 10⁴ gets ~10⁻³.
  double loop_loss_scale = 3.0;
  int max_iterations = 100;         ///< Levenberg–Marquardt iterations
  /// Stop when a step lowers the cost by less than this fraction. From a chordal start the first
  /// one or two steps do nearly all the work and LM then creeps (Gauss–Newton under-estimates the
  /// decrease on these non-zero-residual problems); 1e-4 stops there, within 0.05 % of the
  /// published optima on sphere2500/torus3D/manhattan/CSAIL (docs/pose_graph.md).
  double function_tolerance = 1e-4;
  double gradient_tolerance = 1e-10;
  double parameter_tolerance = 1e-9;
  int threads = 1;                  ///< threads for residual/Jacobian evaluation
  bool verbose = false;             ///< Ceres progress to stderr
  /// The SLAM run puts a gravity-direction prior (graph/gravity_prior.hpp) on every keyframe
  /// whose scan has an IMU gravity measurement (a sequence's gravity.txt); without data, none.
  bool gravity_prior = true;
  /// ° per axis of those priors; 0 = the σ the recording states with each measurement. (How
  /// frame-to-map runs scale them, and when a run without loops is optimised with them alone,
  /// are constants in src/pipeline/back_end.cpp.)
  double gravity_sigma_deg = 0.0;
};

/// The field table (keys, ranges, docs; core/config_fields.hpp, docs/configuration.md).
const ConfigFields<PoseGraphConfig>& configFields(ConfigTag<PoseGraphConfig>);

/// Reads the `graph:` section (or the whole document when it has none) of a YAML file; keys are
/// the field names above, enums as strings. Unknown keys are an error naming the file and key.
PoseGraphConfig loadPoseGraphConfig(const std::filesystem::path& yaml_file);

struct PoseGraphReport {
  /// Costs (no ½, no robust loss) after initialisation; with gravity priors each includes
  /// their cost (graph/gravity_prior.hpp), so the guard below compares the whole objective.
  double initial_geodesic = 0.0;
  double initial_chordal = 0.0;
  double final_geodesic = 0.0;
  double final_chordal = 0.0;
  int iterations = 0;             ///< LM iterations (successful + unsuccessful)
  double init_seconds = 0.0;      ///< time of the initialisation step
  double solve_seconds = 0.0;     ///< time of the Ceres solve
  double total_seconds = 0.0;
  bool converged = false;         ///< Ceres reached a convergence criterion
  std::string message;            ///< Ceres' termination message
};

/// Optimises `graph.poses` in place. Throws hazmap::Error when the graph is not optimisable
/// (see checkOptimisable) or the configuration is invalid.
PoseGraphReport optimizePoseGraph(PoseGraph& graph, const PoseGraphConfig& config = {});

/// The back end's guarded optimisation: as optimizePoseGraph, but a graph that cannot be solved
/// (not optimisable, Ceres failure, a non-finite solution or a higher cost) leaves `graph.poses`
/// as they were and returns why in `failure` (empty on success).
PoseGraphReport optimizePoseGraphOrKeep(PoseGraph& graph, const PoseGraphConfig& config, std::string& failure);

/// Indices of the edges of `kind` whose whitened squared residual (geodesic, no robust loss)
/// exceeds `threshold` in the current poses: loops the solution could not agree with.
std::vector<std::size_t> edgesBeyond(const PoseGraph& graph, EdgeKind kind, double threshold);

}  // namespace hazmap
