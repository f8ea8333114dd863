#pragma once
// Pose graph (paper section V, eq. 3): nodes are robot poses T_world_node, edges are measured
// relative poses T_from_to with an information matrix (inverse covariance).
//
// Conventions (see DEVELOPERS.md and include/hazmap/core/se3.hpp):
// - Information matrices are 6×6, TRANSLATION FIRST [x y z rx ry rz].
// - They are expressed for a LEFT perturbation of the measurement, like every covariance in
//   hazmap: the true relative pose is exp(ξ)·T_from_to with ξ ~ N(0, information⁻¹). So the
//   covariance returned by registration (target ← source) can be inverted and used as it is for an
//   edge from = target node, to = source node. (g2o files store the information for a RIGHT
//   perturbation T_from_to·exp(ξ); graph/g2o.hpp converts on import and export.)
// - 2-D graphs (dimension 2) keep every pose in the plane z = 0 with rotations about z only; only
//   the [x y rz] rows/columns (indices 0, 1, 5) of their information matrices are used.
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "hazmap/core/se3.hpp"

namespace hazmap {

/// Odometry edges join consecutive poses; loop edges come from place recognition and may be wrong,
/// so the optimiser can put a robust loss on them.
/// Odometry: consecutive increments. Loop: verified loop closures (robust loss). MapAnchor: the
/// relative pose frame-to-map tracking measured between a keyframe and an earlier one whose
/// points were in the map it registered to (no robust loss; g2o files do not distinguish it).
enum class EdgeKind { Odometry, Loop, MapAnchor };

struct PoseGraphEdge {
  int from = 0;  ///< node index (not id)
  int to = 0;    ///< node index (not id)
  Eigen::Isometry3d T_from_to = Eigen::Isometry3d::Identity();  ///< measured relative pose
  Matrix6d information = Matrix6d::Identity();  ///< translation first, left perturbation
  EdgeKind kind = EdgeKind::Odometry;
};

/// A unary prior on a node's roll and pitch: the direction of gravity ("down", a unit vector)
/// an IMU measured in the node's frame, with σ (rad) per axis (graph/gravity_prior.hpp).
struct GravityPrior {
  int node = 0;  ///< node index
  Eigen::Vector3d down = Eigen::Vector3d(0.0, 0.0, -1.0);
  double sigma = 0.0;  ///< rad
};

struct PoseGraph {
  int dimension = 3;  ///< 3 = SE(3) graph, 2 = SE(2) graph (poses in the plane z = 0)
  std::vector<Eigen::Isometry3d> poses;  ///< T_world_node, indexed by node index
  std::vector<std::int64_t> ids;         ///< external id of each node (g2o vertex id)
  std::vector<PoseGraphEdge> edges;
  int fixed_node = 0;  ///< index of the node held fixed (gauge); 0 = the first node
  std::vector<GravityPrior> gravity_priors;
  /// Gravity ("down") in the world frame the priors are measured against. The world is the
  /// fixed node's frame, which need not be level, so it is estimated with the poses whenever
  /// there are priors (2 degrees of freedom; initialised from the priors and current poses).
  Eigen::Vector3d gravity_world = Eigen::Vector3d(0.0, 0.0, -1.0);

  /// Appends a node and returns its index. id < 0 means "use the index as id".
  int addNode(const Eigen::Isometry3d& T_world_node, std::int64_t id = -1);
  /// Appends an edge between node indices; returns the edge index. Throws hazmap::Error on an
  /// index out of range, a self-loop, non-finite values or an information matrix that is not
  /// symmetric positive definite (on the [x y rz] block for 2-D graphs).
  int addEdge(int from, int to, const Eigen::Isometry3d& T_from_to, const Matrix6d& information,
              EdgeKind kind = EdgeKind::Odometry);

  /// Appends a gravity prior (3-D graphs); throws hazmap::Error on a node out of range, a
  /// direction that is not a finite unit vector or σ ≤ 0. Returns its index.
  int addGravityPrior(int node, const Eigen::Vector3d& down, double sigma);

  int numNodes() const { return static_cast<int>(poses.size()); }
  int numEdges() const { return static_cast<int>(edges.size()); }
  int numLoopEdges() const;
};

/// Connected components (edges taken undirected): component index of every node.
std::vector<int> connectedComponents(const PoseGraph& graph, int* num_components = nullptr);

/// Throws hazmap::Error("<where>: ...") when the graph cannot be optimised: no nodes, bad fixed
/// node, non-finite poses, or nodes not connected to the fixed node (reports how many and one).
void checkOptimisable(const PoseGraph& graph, const std::string& where = "pose graph");

/// Re-initialises every pose by composing edges outward from the fixed node: odometry edges
/// first (breadth first), then loop edges for nodes the odometry edges do not reach. Nodes that
/// no edge reaches keep their pose. Returns the number of nodes reached (fixed node included).
int initialiseFromOdometry(PoseGraph& graph);

/// Right-perturbation (g2o / measurement frame) information from the left-perturbation one stored
/// in an edge: Ω_right = Ad(T)ᵀ Ω_left Ad(T). And back.
Matrix6d informationLeftToRight(const Eigen::Isometry3d& T_from_to, const Matrix6d& left);
Matrix6d informationRightToLeft(const Eigen::Isometry3d& T_from_to, const Matrix6d& right);

/// Indices of the 2-D [x y rz] block inside a 6×6 translation-first matrix.
inline constexpr int kPlanarIndex[3] = {0, 1, 5};

/// Puts a pose in the plane: keeps x, y and the yaw, zeroes z, roll and pitch.
Eigen::Isometry3d planarized(const Eigen::Isometry3d& T);

}  // namespace hazmap
