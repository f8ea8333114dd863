#pragma once
// The gravity-direction prior of a pose-graph node (what LIO-SAM's IMU factor and Cartographer's
// 3-D gravity alignment add to a LiDAR back end): an accelerometer at rest measures gravity, so
// each node's roll and pitch are observed absolutely; yaw and position are not.
//
// Residual (2-D, whitened): r = Bᵀ (R_world_nodeᵀ g_world) / σ, where the measured direction m
// is a unit vector in the node's frame and B = [b₁ b₂] an orthonormal basis of the plane
// perpendicular to m. r = 0 when the node's rotation maps world "down" onto m; a tilt θ away
// from it gives |r| = sin θ / σ. g_world (unit) is a shared unknown with 2 degrees of freedom:
// the graph's world is its fixed node's frame, which need not be level.
#include <Eigen/Core>

#include "hazmap/graph/pose_graph.hpp"

namespace hazmap {

/// The whitened residual of one prior for the node rotation R_world_node and world down g.
Eigen::Vector2d gravityResidual(const GravityPrior& prior, const Eigen::Matrix3d& R_world_node,
                                const Eigen::Vector3d& gravity_world);

/// Σ ‖r‖² over the graph's priors at its current poses and gravity_world (no ½, like the edge
/// costs of graph/costs.hpp, which include it).
double gravityPriorCost(const PoseGraph& graph);

/// The world "down" the priors agree on best at the current poses: the normalised mean of
/// R_world_node · m weighted by 1/σ² (the least-squares start for the optimiser).
Eigen::Vector3d meanGravityWorld(const PoseGraph& graph);

}  // namespace hazmap
