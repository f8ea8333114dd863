#pragma once
// Ceres residuals of the pose-graph costs (graph/costs.hpp) with analytic Jacobians.
//
// 3-D parameter block: 12 doubles [t (3) | R column-major (9)], on SO(3)×R³ with the update
// t ← t + δt, R ← R·Exp(δφ) (PoseManifold3). The cost functions write the Jacobian with respect
// to the 6-D tangent δ = [δt; δφ] into the first 6 columns of the 12-column block (the rest zero)
// and the manifold's PlusJacobian is [I₆; 0], so Ceres' chain rule reproduces the tangent
// Jacobian exactly without differentiating through the rotation matrix entries.
// 2-D parameter block: 3 doubles [x y θ], plain Euclidean (all costs are 2π-periodic in θ).
#include <ceres/ceres.h>

#include <Eigen/Core>
#include <cmath>

#include "hazmap/core/se3.hpp"

namespace hazmap::graph_detail {

using Mat3 = Eigen::Matrix3d;
using Vec3 = Eigen::Vector3d;
using RowJac12 = Eigen::Matrix<double, Eigen::Dynamic, 12, Eigen::RowMajor>;

inline Mat3 skew(const Vec3& v) { return hat(v); }

class PoseManifold3 final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 12; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override {
    Eigen::Map<const Vec3> t(x);
    Eigen::Map<const Mat3> R(x + 3);
    Eigen::Map<const Vec3> dt(delta), dphi(delta + 3);
    Eigen::Map<Vec3>{x_plus_delta} = t + dt;
    Eigen::Map<Mat3>{x_plus_delta + 3} = R * so3Exp(dphi);
    return true;
  }
  bool PlusJacobian(const double*, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, 12, 6, Eigen::RowMajor>> J(jacobian);
    J.setZero();
    J.topRows<6>().setIdentity();
    return true;
  }
  bool Minus(const double* y, const double* x, double* y_minus_x) const override {
    Eigen::Map<const Mat3> Rx(x + 3), Ry(y + 3);
    Eigen::Map<Vec3>{y_minus_x} = Eigen::Map<const Vec3>(y) - Eigen::Map<const Vec3>(x);
    Eigen::Map<Vec3>{y_minus_x + 3} = so3Log(Rx.transpose() * Ry);
    return true;
  }
  bool MinusJacobian(const double*, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, 6, 12, Eigen::RowMajor>> J(jacobian);
    J.setZero();
    J.leftCols<6>().setIdentity();
    return true;
  }
};

/// Geodesic (SO(3)×R³ log) error of E = T̃⁻¹ T_i⁻¹ T_j, whitened by L (Ω̂ = LᵀL).
class GeodesicCost3 final : public ceres::SizedCostFunction<6, 12, 12> {
 public:
  GeodesicCost3(const Mat3& R_meas, const Vec3& t_meas, const Matrix6d& sqrt_information)
      : Rt_(R_meas.transpose()), t_(t_meas), L_(sqrt_information) {}

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    Eigen::Map<const Vec3> ti(p[0]), tj(p[1]);
    Eigen::Map<const Mat3> Ri(p[0] + 3), Rj(p[1] + 3);
    const Mat3 A = Rt_ * Ri.transpose();       // R̃ᵀ R_iᵀ
    const Vec3 d = Ri.transpose() * (tj - ti);  // R_iᵀ (t_j − t_i)
    const Mat3 ER = A * Rj;
    Vector6d e;
    e.head<3>() = Rt_ * (d - t_);
    e.tail<3>() = so3Log(ER);
    Eigen::Map<Vector6d>{residuals} = L_ * e;
    if (!jacobians) return true;
    const Mat3 Jr_inv = so3LeftJacobianInverse(-e.tail<3>());  // J_r⁻¹(φ) = J_l⁻¹(−φ)
    if (jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, 6, 12, Eigen::RowMajor>> J(jacobians[0]);
      Matrix6d D = Matrix6d::Zero();
      D.topLeftCorner<3, 3>() = -A;
      D.topRightCorner<3, 3>() = Rt_ * skew(d);
      D.bottomRightCorner<3, 3>() = -Jr_inv * ER.transpose() * Rt_;
      J.setZero();
      J.leftCols<6>() = L_ * D;
    }
    if (jacobians[1]) {
      Eigen::Map<Eigen::Matrix<double, 6, 12, Eigen::RowMajor>> J(jacobians[1]);
      Matrix6d D = Matrix6d::Zero();
      D.topLeftCorner<3, 3>() = A;
      D.bottomRightCorner<3, 3>() = Jr_inv;
      J.setZero();
      J.leftCols<6>() = L_ * D;
    }
    return true;
  }

 private:
  Mat3 Rt_;  // R̃ᵀ
  Vec3 t_;
  Matrix6d L_;
};

/// SE-Sync's chordal cost κ‖R_j − R_i R̃‖_F² + τ‖t_j − t_i − R_i t̃‖² as 6 residuals:
/// ‖R_j − R_i R̃‖_F² = 2(3 − tr E) = 8 sin²(θ_E/2) = 8‖q_v(E)‖² with E = R̃ᵀ R_iᵀ R_j and q(E) the
/// unit quaternion with q_w ≥ 0, so r = [√(8κ) q_v(E); √τ (t_j − t_i − R_i t̃)] gives exactly the
/// same cost. Unlike the 9 entries of R_j − R_i R̃ (whose second derivative does not vanish with
/// the residual), q_v's second derivative is proportional to q_v, so the Gauss–Newton model stays
/// accurate at the non-zero-residual optimum and LM converges in a few iterations instead of
/// crawling (measured: model/actual decrease ratio ≈ 0.5 with the 9-entry form on torus3D).
class ChordalCost3 final : public ceres::SizedCostFunction<6, 12, 12> {
 public:
  ChordalCost3(const Mat3& R_meas, const Vec3& t_meas, double kappa, double tau)
      : Rt_(R_meas.transpose()), t_(t_meas), sk_(std::sqrt(8.0 * kappa)), st_(std::sqrt(tau)) {}

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    Eigen::Map<const Vec3> ti(p[0]), tj(p[1]);
    Eigen::Map<const Mat3> Ri(p[0] + 3), Rj(p[1] + 3);
    const Mat3 A = Rt_ * Ri.transpose();  // R̃ᵀ R_iᵀ
    const Mat3 E = A * Rj;
    Eigen::Quaterniond q(E);
    if (q.w() < 0.0) q.coeffs() = -q.coeffs();
    Eigen::Map<Vec3>{residuals} = sk_ * q.vec();
    Eigen::Map<Vec3>{residuals + 3} = st_ * (tj - ti - Ri * t_);
    if (!jacobians) return true;
    // d q_v(E·Exp(δ)) = ½ (q_w I + [q_v]×) δ
    const Mat3 Q = 0.5 * sk_ * (q.w() * Mat3::Identity() + skew(q.vec()));
    if (jacobians[0]) {  // E ← Exp(−R̃ᵀ δφ_i) E = E Exp(−Eᵀ R̃ᵀ δφ_i)
      Eigen::Map<Eigen::Matrix<double, 6, 12, Eigen::RowMajor>> J(jacobians[0]);
      J.setZero();
      J.block<3, 3>(0, 3) = -Q * E.transpose() * Rt_;
      J.block<3, 3>(3, 0) = -st_ * Mat3::Identity();
      J.block<3, 3>(3, 3) = st_ * Ri * skew(t_);
    }
    if (jacobians[1]) {
      Eigen::Map<Eigen::Matrix<double, 6, 12, Eigen::RowMajor>> J(jacobians[1]);
      J.setZero();
      J.block<3, 3>(0, 3) = Q;
      J.block<3, 3>(3, 0) = st_ * Mat3::Identity();
    }
    return true;
  }

 private:
  Mat3 Rt_;  // R̃ᵀ
  Vec3 t_;
  double sk_, st_;
};

inline double wrapAngle(double a) { return std::atan2(std::sin(a), std::cos(a)); }

inline Eigen::Matrix2d rot2(double th) {
  Eigen::Matrix2d R;
  R << std::cos(th), -std::sin(th), std::sin(th), std::cos(th);
  return R;
}

/// 2-D geodesic error [x y θ] of E = T̃⁻¹ T_i⁻¹ T_j, whitened by L (3×3).
class GeodesicCost2 final : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  GeodesicCost2(double x, double y, double th, const Eigen::Matrix3d& sqrt_information)
      : Rt_(rot2(th).transpose()), t_(x, y), th_(th), L_(sqrt_information) {}

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const Eigen::Vector2d ti(p[0][0], p[0][1]), tj(p[1][0], p[1][1]);
    const Eigen::Matrix2d RiT = rot2(p[0][2]).transpose();
    const Eigen::Vector2d d = tj - ti;
    Eigen::Vector3d e;
    e.head<2>() = Rt_ * (RiT * d - t_);
    e(2) = wrapAngle(p[1][2] - p[0][2] - th_);
    Eigen::Map<Eigen::Vector3d>{residuals} = L_ * e;
    if (!jacobians) return true;
    if (jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[0]);
      Eigen::Matrix3d D = Eigen::Matrix3d::Zero();
      const double c = std::cos(p[0][2]), s = std::sin(p[0][2]);
      Eigen::Matrix2d dRiT;  // d(R_iᵀ)/dθ_i
      dRiT << -s, c, -c, -s;
      D.topLeftCorner<2, 2>() = -Rt_ * RiT;
      D.block<2, 1>(0, 2) = Rt_ * dRiT * d;
      D(2, 2) = -1.0;
      J = L_ * D;
    }
    if (jacobians[1]) {
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[1]);
      Eigen::Matrix3d D = Eigen::Matrix3d::Zero();
      D.topLeftCorner<2, 2>() = Rt_ * RiT;
      D(2, 2) = 1.0;
      J = L_ * D;
    }
    return true;
  }

 private:
  Eigen::Matrix2d Rt_;
  Eigen::Vector2d t_;
  double th_;
  Eigen::Matrix3d L_;
};

/// 2-D chordal cost with 3 residuals: ‖R_j − R_i R̃‖_F² = 4(1 − cos Δ) = 8 sin²(Δ/2),
/// Δ = θ_j − θ_i − θ̃, so r = [√(8κ) sin(Δ/2); √τ (t_j − t_i − R_i t̃)] (see ChordalCost3).
class ChordalCost2 final : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  ChordalCost2(double x, double y, double th, double kappa, double tau)
      : t_(x, y), th_(th), sk_(std::sqrt(8.0 * kappa)), st_(std::sqrt(tau)) {}

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const Eigen::Vector2d ti(p[0][0], p[0][1]), tj(p[1][0], p[1][1]);
    const Eigen::Matrix2d Ri = rot2(p[0][2]);
    const double half = 0.5 * wrapAngle(p[1][2] - p[0][2] - th_);
    residuals[0] = sk_ * std::sin(half);
    Eigen::Map<Eigen::Vector2d>{residuals + 1} = st_ * (tj - ti - Ri * t_);
    if (!jacobians) return true;
    Eigen::Matrix2d S;
    S << 0, -1, 1, 0;  // dR(θ)/dθ = R S
    const double dr = 0.5 * sk_ * std::cos(half);
    if (jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[0]);
      J.setZero();
      J(0, 2) = -dr;
      J.block<2, 2>(1, 0) = -st_ * Eigen::Matrix2d::Identity();
      J.block<2, 1>(1, 2) = -st_ * Ri * S * t_;
    }
    if (jacobians[1]) {
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[1]);
      J.setZero();
      J(0, 2) = dr;
      J.block<2, 2>(1, 0) = st_ * Eigen::Matrix2d::Identity();
    }
    return true;
  }

 private:
  Eigen::Vector2d t_;
  double th_;
  double sk_, st_;
};

/// Dynamic covariance scaling as an M-estimator (Agarwal et al. 2013): ρ(s) = s for s ≤ Φ,
/// Φ(3s − Φ)/(s + Φ) beyond; ρ'(s) = (2Φ/(s + Φ))², the DCS weight squared; bounded by 3Φ.
class DcsLoss final : public ceres::LossFunction {
 public:
  explicit DcsLoss(double phi) : phi_(phi) {}
  void Evaluate(double s, double rho[3]) const override {
    if (s <= phi_) {
      rho[0] = s;
      rho[1] = 1.0;
      rho[2] = 0.0;
      return;
    }
    const double inv = 1.0 / (s + phi_);
    rho[0] = phi_ * (3.0 * s - phi_) * inv;
    rho[1] = 4.0 * phi_ * phi_ * inv * inv;
    rho[2] = -8.0 * phi_ * phi_ * inv * inv * inv;
  }

 private:
  double phi_;
};

}  // namespace hazmap::graph_detail
