#include "pipeline/edge_noise.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>

namespace hazmap::pipeline_detail {

Matrix6d inverseOf(const Matrix6d& covariance) {
  Eigen::SelfAdjointEigenSolver<Matrix6d> eig(0.5 * (covariance + covariance.transpose()));
  Eigen::Matrix<double, 6, 1> values = eig.eigenvalues().cwiseMax(1e-12);
  return eig.eigenvectors() * values.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
}

namespace {

// The positive semi-definite part of a symmetric matrix (negative eigenvalues set to zero).
Matrix6d positivePart(const Matrix6d& m) {
  Eigen::SelfAdjointEigenSolver<Matrix6d> eig(0.5 * (m + m.transpose()));
  const Eigen::Matrix<double, 6, 1> values = eig.eigenvalues().cwiseMax(0.0);
  return eig.eigenvectors() * values.asDiagonal() * eig.eigenvectors().transpose();
}

// The covariance with its diagonal raised to the σ floors (m, rad); returned with its eigenvalues
// bounded below, so that it inverts.
Matrix6d flooredCovariance(const Matrix6d& covariance, double min_translation_sigma, double min_rotation_sigma) {
  Matrix6d c = 0.5 * (covariance + covariance.transpose());
  for (int i = 0; i < 3; ++i) c(i, i) = std::max(c(i, i), min_translation_sigma * min_translation_sigma);
  for (int i = 3; i < 6; ++i) c(i, i) = std::max(c(i, i), min_rotation_sigma * min_rotation_sigma);
  Eigen::SelfAdjointEigenSolver<Matrix6d> eig(c);
  Eigen::Matrix<double, 6, 1> values = eig.eigenvalues().cwiseMax(1e-12);
  return eig.eigenvectors() * values.asDiagonal() * eig.eigenvectors().transpose();
}

}  // namespace

Vector6d translationRotationDiagonal(double t2, double r2) { return (Vector6d() << t2, t2, t2, r2, r2, r2).finished(); }

EdgeNoise odometryEdgeNoise(const FrameRecord& rec, const SlamConfig& config) {
  if (!rec.icp_used) return {inverseOf(config.wheel_noise.information()), config.wheel_noise.information()};
  const Matrix6d cov = registrationEdgeCovariance(rec, config);
  return {cov, inverseOf(cov)};
}

Matrix6d registrationEdgeCovariance(const FrameRecord& rec, const SlamConfig& config) {
  return flooredCovariance(rec.covariance, config.min_translation_sigma, config.min_rotation_sigma);
}

// Frame to map registers in the world frame, so the registration's own covariance maps to the
// increment's frame by Ad(T_world_prev⁻¹).
Matrix6d guessCovariance(const OdometryFrame& f, OdometryMode mode) {
  if (f.status == FrameStatus::Fallback) return f.covariance;
  if (f.status != FrameStatus::Degenerate || mode != OdometryMode::FrameToMap) return Matrix6d::Zero();
  const Matrix6d Ad = adjoint((f.pose * f.increment.inverse()).inverse());
  return positivePart(f.covariance - Ad * f.registration.covariance * Ad.transpose());
}

}  // namespace hazmap::pipeline_detail
