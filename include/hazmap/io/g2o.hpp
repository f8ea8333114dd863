#pragma once
// g2o pose-graph files: VERTEX_SE3:QUAT / EDGE_SE3:QUAT (3-D) and VERTEX_SE2 / EDGE_SE2 (2-D).
//   VERTEX_SE3:QUAT id x y z qx qy qz qw
//   EDGE_SE3:QUAT   i j x y z qx qy qz qw  I11 I12 … I16 I22 … I66   (upper triangle, x y z qx qy qz)
//   VERTEX_SE2      id x y θ
//   EDGE_SE2        i j x y θ  I11 I12 I13 I22 I23 I33
//   FIX id          (optional: the node held fixed; default the first vertex)
// The file's information is for a right perturbation (measurement frame); PoseGraphEdge stores
// the left-perturbation form (pose_graph.hpp) and the conversion is exact both ways. The rotation
// block is read as information on the rotation vector (as GTSAM and SE-Sync do).
// Files without vertex lines get their poses by composing odometry edges from the first node.
// Edges between consecutive ids (|i − j| = 1) are odometry, the others loop edges.
#include <filesystem>
#include <string>
#include <vector>

#include "hazmap/graph/pose_graph.hpp"

namespace hazmap {

struct G2oReadInfo {
  bool had_vertices = false;  ///< false: poses were composed from odometry edges
  int vertex_lines = 0;
  int edge_lines = 0;
  /// Lines whose information matrix was not positive definite and was changed (G2oInformation).
  std::vector<int> adjusted_lines;
};

/// What to do with an edge whose information matrix is not positive definite. Files of the
/// standard benchmark collection (e.g. cubicle.g2o) have translation–rotation couplings that make
/// it indefinite.
enum class G2oInformation {
  Strict,                   ///< refuse: "<file>:<line>: information matrix is not positive definite"
  NearestPositiveDefinite,  ///< the nearest positive-definite matrix (eigenvalues clamped to
                            ///< 1e-9 of the largest); for costs that use the whole matrix
  DiagonalBlocks,           ///< only the translation and rotation blocks, as SE-Sync reads them:
                            ///< its chordal objective uses nothing else (isotropic τ, κ)
};

/// Reads a g2o file. Errors are one line "<file>:<line>: <problem>" (wrong token count, unknown
/// tag, NaN/inf, non-positive-definite information, edge to a missing vertex, duplicate vertex,
/// mixed 2-D/3-D). A disconnected graph is read (checkOptimisable reports it).
PoseGraph readG2o(const std::filesystem::path& path, G2oReadInfo* info = nullptr,
                  G2oInformation policy = G2oInformation::Strict);

/// Parses g2o text; `name` is used in error messages.
PoseGraph parseG2o(const std::string& text, const std::string& name, G2oReadInfo* info = nullptr,
                   G2oInformation policy = G2oInformation::Strict);

/// Writes vertices (full precision) and edges, atomically.
void writeG2o(const std::filesystem::path& path, const PoseGraph& graph);

/// The g2o text of a graph.
std::string formatG2o(const PoseGraph& graph);

}  // namespace hazmap
