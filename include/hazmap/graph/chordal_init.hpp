#pragma once
// Chordal initialisation (Carlone et al., "Initialization techniques for 3D SLAM", ICRA 2015;
// the first stage of SE-Sync's rounding): with the chordal weights κ, τ of costs.hpp,
//  1. rotations: minimise Σ κ ‖R_j − R_i R̃_ij‖_F² over unconstrained 3×3 (2×2) matrices with the
//     fixed node's rotation held — a sparse linear least-squares problem whose three rows
//     decouple — then project every matrix to the nearest rotation;
//  2. translations: with those rotations, minimise Σ τ ‖t_j − t_i − R_i t̃_ij‖² (linear).
// Reaches the basin of the global optimum where local solvers started from odometry do not
// (torus3D).
#include "hazmap/graph/pose_graph.hpp"

namespace hazmap {

/// Overwrites every pose but the fixed one. The graph must be connected (checkOptimisable).
void chordalInitialisation(PoseGraph& graph);

}  // namespace hazmap
