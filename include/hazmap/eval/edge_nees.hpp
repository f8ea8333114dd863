#pragma once
// Consistency of a pose graph's edge information against the truth: the normalised estimation
// error squared (NEES) of every edge,
//   e = Log(T_true_ij · T̃_ij⁻¹)  (se3Log, translation first),   NEES = eᵀ Ω e,
// T̃_ij the edge's measured relative pose, T_true_ij = T_true_i⁻¹ T_true_j, Ω its information.
// PoseGraphEdge keeps Ω for a LEFT perturbation (pose_graph.hpp: the true relative pose is
// exp(ξ)·T̃_ij), so the error that Ω weighs is ξ = Log(T_true_ij · T̃_ij⁻¹), not
// Log(T̃_ij⁻¹ · T_true_ij) (that one goes with the right-perturbation information of a g2o file).
// If the covariances are honest, e ~ N(0, Ω⁻¹) and NEES ~ χ²(6): mean 6, median 5.35. A mean far
// above 6 means over-confident edges, far below means too timid ones. Per axis, e_k² / (Ω⁻¹)_kk
// has mean 1 when that axis' variance is right (what a per-axis calibration fits).
// 2-D graphs (dimension 2) use the [x y rz] block only: χ²(3), mean 3.
#include <Eigen/Geometry>
#include <array>
#include <span>
#include <string>
#include <vector>

#include "hazmap/core/se3.hpp"
#include "hazmap/graph/pose_graph.hpp"

namespace hazmap {

struct EdgeNees {
  int from = 0, to = 0;
  EdgeKind kind = EdgeKind::Odometry;
  Vector6d error = Vector6d::Zero();  ///< ξ, translation first (m, rad)
  double nees = 0.0;                  ///< ξᵀ Ω ξ
  std::array<double, 6> axis_nees{};  ///< ξ_k² / (Ω⁻¹)_kk (2-D: 0 outside [x y rz])
};

struct NeesStats {
  std::size_t count = 0;
  int dof = 6;               ///< degrees of freedom of the χ² an honest edge follows
  double mean = 0.0;         ///< honest: ≈ dof
  double median = 0.0;       ///< honest: ≈ dof − 2/3 (5.35 for 6)
  double p95 = 0.0;          ///< honest: 12.6 for 6
  double max = 0.0;
  /// Share of edges inside the χ²(dof) 95 % bound (honest: ≈ 0.95).
  double within_95 = 0.0;
  std::array<double, 6> axis_mean{};  ///< per axis mean of ξ_k² / (Ω⁻¹)_kk (honest: 1)
};

struct EdgeNeesReport {
  std::vector<EdgeNees> edges;  ///< in the graph's edge order
  NeesStats odometry, loop, all;
  /// Map-anchor edges (frame to map: tracking's relative pose of a revisit), apart from the
  /// odometry increments since their error is tracking's drift, not one registration's.
  NeesStats map_anchor;
};

/// NEES of every edge of `graph` against the true node poses `truth` (T_world_node for every
/// node index, any world frame). Throws hazmap::Error naming `where` when the counts differ or a
/// pose is not finite.
EdgeNeesReport computeEdgeNees(const PoseGraph& graph, std::span<const Eigen::Isometry3d> truth,
                               const std::string& where = "edge NEES");

/// The error an edge's left-perturbation information weighs: Log(T_true_ij · T̃_ij⁻¹).
Vector6d edgeError(const Eigen::Isometry3d& T_measured, const Eigen::Isometry3d& T_true);

/// Summary of NEES values (dof = 6 for 3-D graphs, 3 for 2-D).
NeesStats summariseNees(const std::vector<const EdgeNees*>& edges, int dof);

/// NEES of the odometry chain over spans of `span` consecutive increments (nodes i → i + span,
/// i = 0, span, 2·span, …, only where every increment has an odometry edge): the measured
/// increments composed, their covariances (each edge's information⁻¹) chained as independent
/// (Σ = Σ_k Ad(T̃_i,k−1) Σ_k Ad(T̃_i,k−1)ᵀ, first order), against the true relative pose. Span 1 is
/// the odometry edges' own NEES; a chain whose increment errors are correlated (frame-to-map
/// tracking's slowly varying map drift) is honest per edge and over-confident over long spans.
NeesStats odometrySpanNees(const PoseGraph& graph, std::span<const Eigen::Isometry3d> truth, int span);

/// JSON of the report's three summaries ({"odometry": {...}, "loop": {...}, "all": {...}}), and
/// with `per_edge` also the edges (from, to, kind, nees, error).
std::string toJson(const EdgeNeesReport& report, bool per_edge = false);
/// JSON of one summary (count, dof, mean, median, p95, max, within_95, axis_mean).
std::string toJson(const NeesStats& stats);
/// A few lines for a person.
std::string toText(const EdgeNeesReport& report);

}  // namespace hazmap
