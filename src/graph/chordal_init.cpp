#include "hazmap/graph/chordal_init.hpp"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cmath>
#include <vector>

#include "hazmap/core/error.hpp"
#include "hazmap/graph/costs.hpp"

namespace hazmap {

namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

Eigen::MatrixXd solveSpd(int n, const Triplets& triplets, const Eigen::MatrixXd& rhs,
                         const char* what) {
  Eigen::SparseMatrix<double> H(n, n);
  H.setFromTriplets(triplets.begin(), triplets.end());  // sums duplicates
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> llt(H);
  if (llt.info() != Eigen::Success)
    fail("chordal initialisation", std::string(what) + " system is singular (graph disconnected?)");
  Eigen::MatrixXd x = llt.solve(rhs);
  if (!x.allFinite()) fail("chordal initialisation", std::string(what) + " solve gave NaN");
  return x;
}

Eigen::Matrix2d projectToSO2(const Eigen::Matrix2d& M) {
  const double angle = std::atan2(M(1, 0) - M(0, 1), M(0, 0) + M(1, 1));
  return Eigen::Rotation2Dd(angle).toRotationMatrix();
}

// Step 1, rotations. Row r of every rotation, x_k = R_k[r,:]ᵀ, satisfies x_j − R̃ᵀ x_i = 0 for
// every edge, with the same matrix for all r: one sparse normal-equation solve, d right sides.
void solveRotations(PoseGraph& graph, const std::vector<int>& var, int m, const std::vector<ChordalWeights>& weights) {
  const int n = graph.numNodes();
  const int d = graph.dimension == 2 ? 2 : 3;
  const int fixed = graph.fixed_node;
  Triplets trip;
  trip.reserve(graph.edges.size() * 4 * d * d);
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(d * m, d);
  const Eigen::MatrixXd R_fixed = graph.poses[fixed].linear().topLeftCorner(d, d);
  for (std::size_t k = 0; k < graph.edges.size(); ++k) {
    const auto& e = graph.edges[k];
    const double w = weights[k].kappa;
    const Eigen::MatrixXd Rt = e.T_from_to.linear().topLeftCorner(d, d);
    // Residual blocks: B_i = −R̃ᵀ on x_i, B_j = I on x_j.
    // H_ii += w R̃ R̃ᵀ = w I, H_jj += w I, H_ij += w B_iᵀ B_j = −w R̃, H_ji = −w R̃ᵀ.
    const int vi = var[e.from], vj = var[e.to];
    for (int a = 0; a < d; ++a) {
      if (vi >= 0) trip.emplace_back(d * vi + a, d * vi + a, w);
      if (vj >= 0) trip.emplace_back(d * vj + a, d * vj + a, w);
    }
    if (vi >= 0 && vj >= 0) {
      for (int a = 0; a < d; ++a)
        for (int b = 0; b < d; ++b) {
          trip.emplace_back(d * vi + a, d * vj + b, -w * Rt(a, b));
          trip.emplace_back(d * vj + b, d * vi + a, -w * Rt(a, b));
        }
    } else if (vi >= 0) {  // x_j known: b_i −= w B_iᵀ x_j = w R̃ x_j
      for (int r = 0; r < d; ++r)
        rhs.block(d * vi, r, d, 1) += w * Rt * R_fixed.row(r).transpose();
    } else if (vj >= 0) {  // x_i known: b_j −= w B_jᵀ B_i x_i = w R̃ᵀ x_i
      for (int r = 0; r < d; ++r)
        rhs.block(d * vj, r, d, 1) += w * Rt.transpose() * R_fixed.row(r).transpose();
    }
  }
  const Eigen::MatrixXd x = solveSpd(d * m, trip, rhs, "rotation");
  for (int i = 0; i < n; ++i) {
    if (var[i] < 0) continue;
    Eigen::MatrixXd M(d, d);
    for (int r = 0; r < d; ++r) M.row(r) = x.block(d * var[i], r, d, 1).transpose();
    Eigen::Isometry3d& T = graph.poses[i];
    if (d == 2) {
      T.linear().setIdentity();
      T.linear().topLeftCorner<2, 2>() = projectToSO2(M);
    } else {
      T.linear() = projectToSO3(M);
    }
  }
}

// Step 2, translations (rotations fixed): t_j − t_i = R_i t̃_ij, a weighted graph Laplacian, d right sides.
void solveTranslations(PoseGraph& graph, const std::vector<int>& var, int m, const std::vector<ChordalWeights>& weights) {
  const int n = graph.numNodes();
  const int d = graph.dimension == 2 ? 2 : 3;
  const int fixed = graph.fixed_node;
  Triplets trip;
  trip.reserve(graph.edges.size() * 4);
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(m, d);
  const Eigen::VectorXd t_fixed = graph.poses[fixed].translation().head(d);
  for (std::size_t k = 0; k < graph.edges.size(); ++k) {
    const auto& e = graph.edges[k];
    const double w = weights[k].tau;
    const Eigen::VectorXd c =
        (graph.poses[e.from].linear() * e.T_from_to.translation()).head(d);
    const int vi = var[e.from], vj = var[e.to];
    if (vi >= 0) {
      trip.emplace_back(vi, vi, w);
      rhs.row(vi) -= w * c.transpose();
    }
    if (vj >= 0) {
      trip.emplace_back(vj, vj, w);
      rhs.row(vj) += w * c.transpose();
    }
    if (vi >= 0 && vj >= 0) {
      trip.emplace_back(vi, vj, -w);
      trip.emplace_back(vj, vi, -w);
    } else if (vi >= 0) {
      rhs.row(vi) += w * t_fixed.transpose();
    } else if (vj >= 0) {
      rhs.row(vj) += w * t_fixed.transpose();
    }
  }
  const Eigen::MatrixXd x = solveSpd(m, trip, rhs, "translation");
  for (int i = 0; i < n; ++i) {
    if (var[i] < 0) continue;
    graph.poses[i].translation().setZero();
    graph.poses[i].translation().head(d) = x.row(var[i]).transpose();
  }
}

}  // namespace

void chordalInitialisation(PoseGraph& graph) {
  checkOptimisable(graph, "chordal initialisation");
  const int n = graph.numNodes();
  const int fixed = graph.fixed_node;
  // Unknown index of every node (the fixed node has none).
  std::vector<int> var(n, -1);
  int m = 0;
  for (int i = 0; i < n; ++i)
    if (i != fixed) var[i] = m++;
  if (m == 0) return;

  std::vector<ChordalWeights> weights;
  weights.reserve(graph.edges.size());
  for (const auto& e : graph.edges) weights.push_back(chordalWeights(e, graph.dimension));

  solveRotations(graph, var, m, weights);
  solveTranslations(graph, var, m, weights);
}

}  // namespace hazmap
