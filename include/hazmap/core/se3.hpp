#pragma once
// SE(3) helpers on Eigen::Isometry3d.
//
// CONVENTION (used everywhere in hazmap): a 6-vector tangent ξ = [ρ; φ] is TRANSLATION FIRST,
// rotation second — the g2o / Ceres pose_graph_3d order. 6×6 covariances and information
// matrices use the same order. A perturbation is applied on the LEFT: T' = exp(ξ) · T.
// Code that talks to a rotation-first library converts with swapTranslationRotation().
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hazmap {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// Skew-symmetric matrix [v]× with [v]× w = v × w.
Eigen::Matrix3d hat(const Eigen::Vector3d& v);

Eigen::Matrix3d so3Exp(const Eigen::Vector3d& phi);
Eigen::Vector3d so3Log(const Eigen::Matrix3d& R);
/// Left Jacobian of SO(3) and its inverse.
Eigen::Matrix3d so3LeftJacobian(const Eigen::Vector3d& phi);
Eigen::Matrix3d so3LeftJacobianInverse(const Eigen::Vector3d& phi);

/// SE(3) exponential of ξ = [ρ; φ]: R = exp(φ), t = J_l(φ) ρ.
Eigen::Isometry3d se3Exp(const Vector6d& xi);
/// Inverse of se3Exp.
Vector6d se3Log(const Eigen::Isometry3d& T);

/// Adjoint in the translation-first order: Ad_T ξ = log(T exp(ξ) T⁻¹).
Matrix6d adjoint(const Eigen::Isometry3d& T);

/// Reorders a 6-vector / 6×6 matrix between translation-first and rotation-first.
Vector6d swapTranslationRotation(const Vector6d& v);
Matrix6d swapTranslationRotation(const Matrix6d& m);

/// Builds an isometry from translation and roll/pitch/yaw (Z-Y-X, radians).
Eigen::Isometry3d fromXyzRpy(double x, double y, double z, double roll, double pitch, double yaw);
/// Planar pose (x, y, yaw) as an isometry.
Eigen::Isometry3d fromXyYaw(double x, double y, double yaw);
/// Yaw (rotation about z) of a pose, radians in (-π, π].
double yawOf(const Eigen::Isometry3d& T);

/// Rotation angle (radians) and translation norm of a relative pose.
double rotationAngle(const Eigen::Isometry3d& T);
double translationNorm(const Eigen::Isometry3d& T);

/// Projects an (almost) rotation matrix to the nearest rotation (SVD, det = +1).
Eigen::Matrix3d projectToSO3(const Eigen::Matrix3d& M);

/// Re-orthonormalises a pose's rotation (keeps drift from accumulating when composing).
Eigen::Isometry3d normalized(const Eigen::Isometry3d& T);

/// True when every entry of the pose is finite.
bool isFinite(const Eigen::Isometry3d& T);

}  // namespace hazmap
