#pragma once
// Internal (not API): the ICP's residual kinds as "factors". A factor is one correspondence's
// residual and Jacobian at a pose (perturbation on the left, translation first: T' = exp(ξ) T),
// and the two places they enter: the Gauss–Newton normal equations of the step (StepSums) and
// the sandwich covariance at the solution (CovarianceSums). Both read the same residual and
// Jacobian, so the step and the covariance cannot disagree about what a pair contributes.
//
//   PlaneFactor          point-to-plane: r = n·(p − q), J = [n, p × n]
//   PointFactor          point-to-point (the point metric, or a property pair without a usable
//                        normal): r = p − q, J = [I, −p^]
//   PropertyPairFactor   a labelled point and its same-class partner under the plane metric: the
//                        3-D residual split into its along-normal part (full weight) and its
//                        in-plane part (weight property_tangent_weight, mixed by TangentMix)
#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdint>
#include <vector>

#include "hazmap/core/se3.hpp"
#include "hazmap/registration/registration.hpp"

namespace hazmap::detail {

enum class FactorKind : std::uint8_t { Plane, Point, PropertyPair };

/// A 3-D factor's residual (PropertyPair, Point) or a plane's signed distance.
inline bool isPointFactor(FactorKind kind) { return kind != FactorKind::Plane; }

// A property pair's 3-D residual r = p − q with its in-plane part scaled by `s`:
// M r, M = n nᵀ + s (I − n nᵀ). Used for the robust weight of the pair.
inline Eigen::Vector3f weightedResidual(const Eigen::Vector3f& r, const Eigen::Vector3f& n, double s) {
  const Eigen::Vector3f along = n * n.dot(r);
  return along + static_cast<float>(s) * (r - along);
}

// How a property pair's in-plane information enters the normal equations. In-plane, a labelled
// point and its same-class partner are apart mostly because the scans sampled the patch at
// different spots, so that information gets the small weight w_t — except along directions that
// the rest (plane residuals, along-normal parts) leaves unconstrained, where it is the only
// information there is and gets full weight. With S = diag(1,1,1,1/L,1/L,1/L) and P the
// projector on the degenerate eigenvectors of S·H_geometry·S, a tangent block X becomes
// S⁻¹ (w_t X_s + (1 − w_t) P X_s P) S⁻¹ with X_s = S X S (and g → S⁻¹ (w_t I + (1 − w_t) P) S g).
struct TangentMix {
  double w_t = 1.0;
  Vector6d d = Vector6d::Ones();  ///< diagonal of S
  Matrix6d P = Matrix6d::Zero();
  /// The degenerate eigenvectors of the geometry in pose units (unit, translation first): the
  /// directions only the labelled pairs' in-plane parts constrain.
  std::vector<Vector6d> directions;
  TangentMix() = default;
  TangentMix(const Matrix6d& H_geometry, double pairs_weight, double w_tangent, double length,
             double threshold)
      : w_t(w_tangent) {
    const double L = length > 0.0 ? length : 1.0;
    d << 1, 1, 1, 1.0 / L, 1.0 / L, 1.0 / L;
    const Matrix6d Hs = d.asDiagonal() * H_geometry * d.asDiagonal();
    const Eigen::SelfAdjointEigenSolver<Matrix6d> es(0.5 * (Hs + Hs.transpose()));
    for (int i = 0; i < 6; ++i)
      if (es.eigenvalues()(i) < threshold * pairs_weight) {
        P.noalias() += es.eigenvectors().col(i) * es.eigenvectors().col(i).transpose();
        directions.push_back((d.asDiagonal() * es.eigenvectors().col(i)).normalized());
      }
  }
  Matrix6d operator()(const Matrix6d& X) const {
    const Matrix6d Xs = d.asDiagonal() * X * d.asDiagonal();
    const Matrix6d mixed = w_t * Xs + (1.0 - w_t) * P * Xs * P;
    const Vector6d di = d.cwiseInverse();
    return di.asDiagonal() * mixed * di.asDiagonal();
  }
  Vector6d operator()(const Vector6d& g) const {
    const Vector6d gs = d.asDiagonal() * g;
    return d.cwiseInverse().asDiagonal() * Vector6d(w_t * gs + (1.0 - w_t) * (P * gs));
  }
};

/// The robust kernel at its current scale: the weight w(s) = ψ(s)/s of the reweighted least
/// squares, and the slope factor ψ'(s)/w(s) − 1 = s·w'(s)/w(s) that the covariance's bread needs.
struct RobustKernelAt {
  RobustKernel kernel = RobustKernel::None;
  double scale = 0.0;
  double weight(double s) const {
    switch (kernel) {
      case RobustKernel::None: return 1.0;
      case RobustKernel::Huber: return std::abs(s) <= scale ? 1.0 : scale / std::abs(s);
      case RobustKernel::GemanMcClure: {
        const double a = scale * scale / (scale * scale + s * s);
        return a * a;
      }
    }
    return 1.0;
  }
  double slope(double s) const {
    switch (kernel) {
      case RobustKernel::None: return 0.0;
      case RobustKernel::Huber: return std::abs(s) <= scale ? 0.0 : -1.0;
      case RobustKernel::GemanMcClure: return -4.0 * s * s / (scale * scale + s * s);
    }
    return 0.0;
  }
};

/// The step's weighted sums of one chunk of correspondences. The 3-D factors also accumulate
/// the weighted centroids and cross-covariance of the point metric's closed form (Horn/Umeyama).
struct StepSums {
  Matrix6d H = Matrix6d::Zero();   ///< Σ w JᵀJ (without property pairs' in-plane parts)
  Vector6d g = Vector6d::Zero();   ///< Σ w Jᵀ r
  Matrix6d Ht = Matrix6d::Zero();  ///< property pairs' in-plane parts (see TangentMix)
  Vector6d gt = Vector6d::Zero();
  double wr2 = 0.0, w = 0.0, w1 = 0.0, w3 = 0.0, d2 = 0.0, r2 = 0.0;
  std::size_t n = 0;
  Eigen::Vector3d sp = Eigen::Vector3d::Zero(), sq = Eigen::Vector3d::Zero();
  Eigen::Matrix3d spq = Eigen::Matrix3d::Zero();
  void add(const StepSums& o) {
    H += o.H; g += o.g; Ht += o.Ht; gt += o.gt;
    wr2 += o.wr2; w += o.w; w1 += o.w1; w3 += o.w3; d2 += o.d2; r2 += o.r2; n += o.n;
    sp += o.sp; sq += o.sq; spq += o.spq;
  }
  /// A 3-D pair's share of the closed form's weighted centroids and cross-covariance.
  void addPointPair(double weight, const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
    w3 += weight;
    sp += weight * p;
    sq += weight * q;
    spq.noalias() += weight * p * q.transpose();
  }
};

/// The covariance's sums: the bread (Σ w ψ' JᵀJ; property pairs' in-plane part apart, mixed
/// like the step's), the weighted squared residuals, and the residual components and pair
/// weights that estimate the residual variance. The meat is summed per target point by the
/// caller from each factor's score.
struct CovarianceSums {
  Matrix6d bread = Matrix6d::Zero(), bread_t = Matrix6d::Zero();
  double wr2 = 0.0, components = 0.0, pairs = 0.0;
};

struct PlaneFactor {
  Vector6d J;
  double r;
  /// `p` the source point at the pose, `n` the target point's normal, `residual` n·(p − q).
  PlaneFactor(const Eigen::Vector3d& p, const Eigen::Vector3d& n, double residual) : r(residual) {
    // Written in the pairs the updates read it in: `J << n, p × n` wrote 1 + 2 + 1 + 2 doubles,
    // and each two-double read spanning two writes stalled the store forwarding (a third of
    // the accumulation's time; docs/registration.md).
    const Eigen::Vector3d c = p.cross(n);
    J.segment<2>(0) = n.head<2>();
    J.segment<2>(2) = Eigen::Vector2d(n.z(), c.x());
    J.segment<2>(4) = c.tail<2>();
  }
  void addToStep(StepSums& s, double w) const {
    s.H.noalias() += w * J * J.transpose();
    s.g.noalias() += w * r * J;
    s.wr2 += w * r * r;
    s.r2 += r * r;
    s.w1 += w;
  }
  /// Returns the score w r J (the pair's contribution to the meat).
  Vector6d addToCovariance(CovarianceSums& c, double w, const RobustKernelAt& kernel, const TangentMix&) const {
    c.bread.noalias() += w * (1.0 + kernel.slope(r)) * J * J.transpose();
    c.wr2 += w * r * r;
    c.components += w;
    return w * r * J;
  }
};

struct PointFactor {
  Eigen::Vector3d r;
  Eigen::Matrix<double, 3, 6> J;
  PointFactor(const Eigen::Vector3d& p, const Eigen::Vector3d& q) : r(p - q) {
    J << Eigen::Matrix3d::Identity(), -hat(p);
  }
  void addToStep(StepSums& s, double w) const {
    s.H.noalias() += w * (J.transpose() * J);
    s.g.noalias() += w * (J.transpose() * r);
    const double rn2 = r.squaredNorm();
    s.wr2 += w * rn2;
    s.r2 += rn2;
  }
  Vector6d addToCovariance(CovarianceSums& c, double w, const RobustKernelAt& kernel, const TangentMix&) const {
    const double rn2 = r.squaredNorm();
    // ψ'(r) for a weight of |r|: w (I + slope · r rᵀ/|r|²)
    c.bread.noalias() += w * (J.transpose() * J);
    if (rn2 > 0.0) {
      const double slope = kernel.slope(std::sqrt(rn2));
      const Vector6d Jr = J.transpose() * r;
      c.bread.noalias() += (w * slope / rn2) * Jr * Jr.transpose();
    }
    c.wr2 += w * rn2;
    c.components += 3.0 * w;
    return w * (J.transpose() * r);
  }
};

struct PropertyPairFactor {
  PointFactor point;
  Eigen::Vector3d n;
  Vector6d Jn;       ///< Jacobian of the along-normal part n·r
  double rn;         ///< n·r
  Eigen::Matrix3d Pt;  ///< projector on the tangent plane
  double tangent_weight;
  PropertyPairFactor(const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& normal,
                     double w_tangent)
      : point(p, q), n(normal), tangent_weight(w_tangent) {
    Jn = point.J.transpose() * n;
    rn = n.dot(point.r);
    Pt = Eigen::Matrix3d::Identity() - n * n.transpose();
  }
  /// rn² + w_t |r_tangent|²
  double squaredError() const {
    return rn * rn + tangent_weight * (point.r.squaredNorm() - rn * rn);
  }
  void addToStep(StepSums& s, double w) const {
    s.H.noalias() += w * Jn * Jn.transpose();
    s.g.noalias() += w * rn * Jn;
    s.Ht.noalias() += w * (point.J.transpose() * Pt * point.J);
    s.gt.noalias() += w * (point.J.transpose() * (Pt * point.r));
    const double rn2 = squaredError();
    s.wr2 += w * rn2;
    s.r2 += rn2;
  }
  // Along-normal part as a plane residual; the in-plane part mixed as in the step.
  Vector6d addToCovariance(CovarianceSums& c, double w, const RobustKernelAt&, const TangentMix& mix) const {
    c.bread.noalias() += w * Jn * Jn.transpose();
    c.bread_t.noalias() += w * (point.J.transpose() * Pt * point.J);
    c.wr2 += w * squaredError();
    c.components += w * (1.0 + 2.0 * tangent_weight);
    return w * rn * Jn + mix(Vector6d(w * (point.J.transpose() * (Pt * point.r))));
  }
};

/// Calls `f` with the factor of kind `kind` for source point `p` (at the pose) and target point
/// `q` = target point `index` (`normals` read only by the kinds that use one; a plane's signed
/// distance is `plane_residual`, as searched or recomputed by the caller).
template <class F>
inline void withFactor(FactorKind kind, const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                       const std::vector<Eigen::Vector3f>& normals, std::size_t index,
                       double plane_residual, double tangent_weight, F&& f) {
  switch (kind) {
    case FactorKind::Plane: f(PlaneFactor(p, normals[index].cast<double>(), plane_residual)); return;
    case FactorKind::Point: f(PointFactor(p, q)); return;
    case FactorKind::PropertyPair:
      f(PropertyPairFactor(p, q, normals[index].cast<double>(), tangent_weight));
      return;
  }
}

}  // namespace hazmap::detail
