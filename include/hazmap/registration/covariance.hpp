#pragma once
// Pose covariance of an ICP estimate (translation-first, left perturbation).
//
// The estimate solves Σᵢ Jᵢᵀ ψ(rᵢ) = 0 (ψ(r) = w(r)·r, the robust kernel's influence). Its
// covariance is the M-estimator sandwich
//     Σ_ξ = A⁻¹ M A⁻¹,   A = Σ Jᵢᵀ ψ'(rᵢ) Jᵢ,   M = Σ (Jᵢᵀ ψ(rᵢ)) (Jᵢᵀ ψ(rᵢ))ᵀ,
// evaluated at the solution with the observed residuals (so source and target noise are both in
// it). The caller sums the score terms Jᵢᵀψ(rᵢ) of residuals that share a target point before
// forming M (cluster-robust): those residuals share that point's noise and are correlated. Without a kernel A = H = Σ JᵢᵀJᵢ and, for residuals of equal variance σ², Σ_ξ = σ² H⁻¹ —
// the "Hessian × residual variance" form; for point-to-plane this is Censi's closed form
// (Censi 2007) with correspondences and normals held fixed.
#include <vector>

#include "hazmap/core/se3.hpp"

namespace hazmap {

struct PoseCovariance {
  Matrix6d covariance = Matrix6d::Identity();
  double residual_sigma = 0.0;  ///< σ (m) per residual component
  std::vector<Vector6d> degenerate_directions;
};

/// The degeneracy test alone (poseCovariance's below, and the odometry's in the sensor frame): unit
/// tangent directions (canonical sign) whose eigenvalue of the unit-balanced `H` is below
/// `degeneracy_threshold`·`pairs_weight`.
std::vector<Vector6d> degenerateDirections(const Matrix6d& H, double pairs_weight, double length_scale,
                                           double degeneracy_threshold);

/// `H` = Σ w JᵀJ (used for degeneracy), `bread` = A, `meat` = M, `wr2` = Σ w‖r‖²,
/// `components` = Σ w·(components per residual), `pairs_weight` = Σ w over pairs.
/// Degeneracy: H is scaled to diag(1,1,1,L,L,L)⁻¹·H·diag(…)⁻¹ (L = `length_scale`, m: a rotation
/// of θ counts like a translation of θ·L) and a direction whose eigenvalue is below
/// `degeneracy_threshold`·pairs_weight is reported (a unit vector in the unscaled tangent space):
/// a well-constrained translation direction has an eigenvalue of the order of pairs_weight/3, a
/// direction that nothing constrains (a corridor's axis) close to zero. A⁻¹ is regularised (eigenvalues floored at 1e-9·λ_max of H), so the
/// covariance along a degenerate direction is huge but finite.
PoseCovariance poseCovariance(const Matrix6d& H, const Matrix6d& bread, const Matrix6d& meat,
                              double wr2, double components, double pairs_weight,
                              double length_scale, double degeneracy_threshold);

}  // namespace hazmap
