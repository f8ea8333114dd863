#include "hazmap/registration/covariance.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace hazmap {

std::vector<Vector6d> degenerateDirections(const Matrix6d& H, double pairs_weight, double length_scale,
                                           double degeneracy_threshold) {
  // Unit-balanced: a rotation of θ counts like a translation of θ·L.
  const double L = length_scale > 0.0 ? length_scale : 1.0;
  Vector6d d;
  d << 1, 1, 1, 1.0 / L, 1.0 / L, 1.0 / L;
  const Matrix6d Hs = d.asDiagonal() * H * d.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> ess(0.5 * (Hs + Hs.transpose()));
  std::vector<Vector6d> directions;
  for (int i = 0; i < 6; ++i) {
    if (!(ess.eigenvalues()(i) < degeneracy_threshold * pairs_weight)) continue;
    Vector6d v = d.asDiagonal() * ess.eigenvectors().col(i);
    v.normalize();
    Eigen::Index k;
    v.cwiseAbs().maxCoeff(&k);
    if (v(k) < 0) v = -v;  // canonical sign
    directions.push_back(v);
  }
  return directions;
}

PoseCovariance poseCovariance(const Matrix6d& H, const Matrix6d& bread, const Matrix6d& meat,
                              double wr2, double components, double pairs_weight,
                              double length_scale, double degeneracy_threshold) {
  PoseCovariance out;
  if (!(components > 0.0) || !H.allFinite() || !bread.allFinite() || !meat.allFinite()) {
    out.covariance = Matrix6d::Identity() * 1e6;
    return out;
  }
  out.residual_sigma = std::sqrt(std::max(wr2 / std::max(components - 6.0, 0.5 * components), 0.0));

  const Eigen::SelfAdjointEigenSolver<Matrix6d> eh(0.5 * (H + H.transpose()));
  const double hmax = std::max(eh.eigenvalues().maxCoeff(), 1e-300);
  // A redescending kernel can make A indefinite for a handful of points: fall back to H then.
  const Eigen::SelfAdjointEigenSolver<Matrix6d> ea(0.5 * (bread + bread.transpose()));
  const bool bread_ok = ea.eigenvalues().minCoeff() > 1e-6 * hmax;
  const auto& es = bread_ok ? ea : eh;
  Vector6d inv;
  for (int i = 0; i < 6; ++i) inv(i) = 1.0 / std::max(es.eigenvalues()(i), 1e-9 * hmax);
  const Matrix6d Ainv = es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose();
  out.covariance = Ainv * meat * Ainv;
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose());

  out.degenerate_directions = degenerateDirections(H, pairs_weight, length_scale, degeneracy_threshold);
  return out;
}

}  // namespace hazmap
