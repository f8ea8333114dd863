#pragma once
// The two cost models of the pose-graph optimiser, evaluable on any graph.
//
// geodesic (g2o / GTSAM convention, the default for SLAM):
//   E_ij = T̃_ij⁻¹ · T_i⁻¹ · T_j   (the error transform, in the measurement frame)
//   e_ij = [ t(E_ij) ; Log(R(E_ij)) ]  (translation first, SO(3)×R³ log map)
//   χ²   = Σ e_ijᵀ Ω̂_ij e_ij, Ω̂_ij the edge information in the measurement frame (what a g2o file
//   stores; PoseGraphEdge keeps the left-perturbation form, see pose_graph.hpp). No ½.
//   2-D graphs: e = [x y θ] of E_ij with θ wrapped to (-π, π], weighted by the [x y rz] block.
//
// chordal (SE-Sync, Rosen et al. IJRR 2019), isotropic weights from the same Ω̂_ij:
//   F = Σ κ_ij ‖R_j − R_i R̃_ij‖_F² + τ_ij ‖t_j − t_i − R_i t̃_ij‖²        (no ½)
//   3-D: τ = 3 / tr(Ω̂_tt⁻¹), κ = 3 / (2 tr(Ω̂_RR⁻¹));  2-D: τ = 2 / tr(Ω̂_xy⁻¹), κ = Ω̂_θθ.
//   With these weights F equals the objective whose global optima SE-Sync publishes (F*).
#include "hazmap/graph/pose_graph.hpp"

namespace hazmap {

enum class PoseGraphCost { Geodesic, Chordal };

/// "geodesic" / "chordal" (throws hazmap::Error naming `where` on anything else).
PoseGraphCost parsePoseGraphCost(const std::string& name, const std::string& where = "cost");
const char* toString(PoseGraphCost cost);

struct ChordalWeights {
  double kappa = 0.0;  ///< rotation weight κ
  double tau = 0.0;    ///< translation weight τ
};

/// κ and τ of one edge (from its information in the measurement frame).
ChordalWeights chordalWeights(const PoseGraphEdge& edge, int dimension);

/// Error vector of one edge in the measurement frame: [t; Log R] (3-D) or [x y 0 0 0 θ] (2-D).
Vector6d geodesicError(const PoseGraph& graph, const PoseGraphEdge& edge);

/// Cost of one edge under each model (no ½, no robust loss).
double geodesicEdgeCost(const PoseGraph& graph, const PoseGraphEdge& edge);
double chordalEdgeCost(const PoseGraph& graph, const PoseGraphEdge& edge);

/// Total costs over all edges (no ½, no robust loss).
double geodesicCost(const PoseGraph& graph);
double chordalCost(const PoseGraph& graph);
double poseGraphCost(const PoseGraph& graph, PoseGraphCost cost);

}  // namespace hazmap
