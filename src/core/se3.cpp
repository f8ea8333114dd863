#include "hazmap/core/se3.hpp"

#include <Eigen/SVD>
#include <cmath>

namespace hazmap {

Eigen::Matrix3d hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

Eigen::Matrix3d so3Exp(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  if (theta < 1e-12) return Eigen::Matrix3d::Identity() + hat(phi);
  return Eigen::AngleAxisd(theta, phi / theta).toRotationMatrix();
}

Eigen::Vector3d so3Log(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

Eigen::Matrix3d so3LeftJacobian(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  const Eigen::Matrix3d K = hat(phi);
  if (theta < 1e-6) return Eigen::Matrix3d::Identity() + 0.5 * K + K * K / 6.0;
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() + (1.0 - std::cos(theta)) / t2 * K +
         (theta - std::sin(theta)) / (t2 * theta) * K * K;
}

Eigen::Matrix3d so3LeftJacobianInverse(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  const Eigen::Matrix3d K = hat(phi);
  if (theta < 1e-6) return Eigen::Matrix3d::Identity() - 0.5 * K + K * K / 12.0;
  const double half = 0.5 * theta;
  const double cot_half = std::cos(half) / std::sin(half);
  return Eigen::Matrix3d::Identity() - 0.5 * K +
         (1.0 / (theta * theta)) * (1.0 - half * cot_half) * K * K;
}

Eigen::Isometry3d se3Exp(const Vector6d& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3Exp(phi);
  T.translation() = so3LeftJacobian(phi) * rho;
  return T;
}

Vector6d se3Log(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d phi = so3Log(T.linear());
  Vector6d xi;
  xi.head<3>() = so3LeftJacobianInverse(phi) * T.translation();
  xi.tail<3>() = phi;
  return xi;
}

Matrix6d adjoint(const Eigen::Isometry3d& T) {
  Matrix6d A = Matrix6d::Zero();
  const Eigen::Matrix3d R = T.linear();
  A.topLeftCorner<3, 3>() = R;
  A.topRightCorner<3, 3>() = hat(T.translation()) * R;
  A.bottomRightCorner<3, 3>() = R;
  return A;
}

Vector6d swapTranslationRotation(const Vector6d& v) {
  Vector6d out;
  out << v.tail<3>(), v.head<3>();
  return out;
}

Matrix6d swapTranslationRotation(const Matrix6d& m) {
  Eigen::PermutationMatrix<6> P;
  P.indices() << 3, 4, 5, 0, 1, 2;
  return P * m * P.transpose();
}

Eigen::Isometry3d fromXyzRpy(double x, double y, double z, double roll, double pitch, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

Eigen::Isometry3d fromXyYaw(double x, double y, double yaw) { return fromXyzRpy(x, y, 0, 0, 0, yaw); }

double yawOf(const Eigen::Isometry3d& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }

double rotationAngle(const Eigen::Isometry3d& T) {
  const double c = std::clamp((T.linear().trace() - 1.0) * 0.5, -1.0, 1.0);
  return std::acos(c);
}

double translationNorm(const Eigen::Isometry3d& T) { return T.translation().norm(); }

Eigen::Matrix3d projectToSO3(const Eigen::Matrix3d& M) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

Eigen::Isometry3d normalized(const Eigen::Isometry3d& T) {
  Eigen::Isometry3d out = T;
  out.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
  return out;
}

bool isFinite(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

}  // namespace hazmap
