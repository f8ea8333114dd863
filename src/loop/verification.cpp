#include "hazmap/loop/verification.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <sstream>

#include "hazmap/core/error.hpp"

namespace hazmap {

// Internal acceptance thresholds of loop verification (issue 37: named constants, not keys; their
// old keys name this file).
/// m / rad; a loop whose ICP covariance has a larger standard deviation is too uncertain to pull
/// the graph (≈ 2° in rotation).
constexpr double kMaxTranslationSigma = 0.25;
constexpr double kMaxRotationSigma = 0.035;
/// m / rad; floors on a loop's standard deviations before inverting, so that no loop becomes rigid.
constexpr double kMinTranslationSigma = 0.01;
constexpr double kMinRotationSigma = 0.001;

namespace {

std::string fmt(double v) {
  std::ostringstream s;
  s.precision(3);
  s << v;
  return s.str();
}

double largestSigma(const Eigen::Matrix3d& block) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(0.5 * (block + block.transpose()));
  return std::sqrt(std::max(0.0, eig.eigenvalues().maxCoeff()));
}

}  // namespace

Matrix6d misfitTerm(const RegistrationResult& reg, const VerificationConfig& c) {
  Matrix6d extra = Matrix6d::Zero();
  if (c.misfit_scale > 0.0 && reg.hessian.allFinite() && reg.hessian.trace() > 0.0) {
    // inlier_rmse² · H⁻¹, eigenvalues of H bounded below (a degenerate loop is rejected before).
    Eigen::SelfAdjointEigenSolver<Matrix6d> eig(0.5 * (reg.hessian + reg.hessian.transpose()));
    const Vector6d values = eig.eigenvalues().cwiseMax(1e-9 * eig.eigenvalues().maxCoeff());
    extra += c.misfit_scale * reg.inlier_rmse * reg.inlier_rmse *
             (eig.eigenvectors() * values.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose());
  }
  return extra;
}

Vector6d floorVariances() {
  Vector6d floor;
  floor << Eigen::Vector3d::Constant(kMinTranslationSigma * kMinTranslationSigma),
      Eigen::Vector3d::Constant(kMinRotationSigma * kMinRotationSigma);
  return floor;
}

void setLoopCovariance(LoopClosure& closure, const Matrix6d& covariance) {
  closure.covariance = covariance;
  const Matrix6d info = covariance.llt().solve(Matrix6d::Identity());
  closure.information = 0.5 * (info + info.transpose());
}

Matrix6d honestyTerms(const RegistrationResult& reg, const VerificationConfig& c) {
  Matrix6d extra = misfitTerm(reg, c);
  const double L = c.icp().degeneracy_length > 0.0 ? c.icp().degeneracy_length : 1.0;
  for (const Vector6d& d : reg.label_only_directions) {
    // d is a unit vector in pose units; in the balanced space (rotation × L) σ is isotropic.
    Vector6d v = d;
    v.tail<3>() *= L;
    const double n = v.norm();
    if (!(n > 0.0)) continue;
    Vector6d u = v / n;
    u.tail<3>() /= L;  // back to pose units: σ along a translation, σ/L along a rotation
    extra += c.label_only_sigma * c.label_only_sigma * u * u.transpose();
  }
  return extra;
}

VerificationResult evaluateRegistration(const LoopCandidate& cand, const RegistrationResult& reg,
                                        const VerificationConfig& c) {
  validate(c);
  VerificationResult out;
  out.registration = reg;
  LoopClosure& lc = out.closure;
  lc.from = cand.match;
  lc.to = cand.query;
  lc.T_from_to = reg.transform;
  lc.source = cand.source;
  lc.fitness = reg.fitness;
  lc.rmse = reg.inlier_rmse;
  auto reject = [&](LoopRejection why, std::string text) {
    out.accepted = false;
    out.rejection = why;
    out.reason = std::move(text);
    return out;
  };
  if (!reg.converged)
    return reject(LoopRejection::NotConverged,
                  "registration did not converge" + (reg.reason.empty() ? "" : ": " + reg.reason));
  if (!isFinite(reg.transform) || !reg.covariance.allFinite())
    return reject(LoopRejection::NonFinite, "non-finite registration result");
  if (reg.fitness < c.min_fitness)
    return reject(LoopRejection::LowFitness, "fitness " + fmt(reg.fitness) + " < " + fmt(c.min_fitness));
  if (reg.inlier_rmse > c.max_rmse)
    return reject(LoopRejection::HighRmse, "rmse " + fmt(reg.inlier_rmse) + " m > " + fmt(c.max_rmse));
  if (c.reject_degenerate && !reg.degenerate_directions.empty())
    return reject(LoopRejection::Degenerate, "degenerate registration (" +
                                                 std::to_string(reg.degenerate_directions.size()) +
                                                 " unconstrained directions)");
  const Eigen::Isometry3d correction = cand.initial_guess.inverse() * reg.transform;
  if (translationNorm(correction) > c.max_correction_translation ||
      rotationAngle(correction) > c.max_correction_rotation)
    return reject(LoopRejection::LargeCorrection, "ICP moved " + fmt(translationNorm(correction)) + " m / " +
                                                      fmt(rotationAngle(correction)) + " rad from the initial guess");

  // Covariance: symmetric, positive definite, bounded.
  Matrix6d cov = 0.5 * c.covariance_scale * (reg.covariance + reg.covariance.transpose());
  Eigen::SelfAdjointEigenSolver<Matrix6d> eig(cov);
  if (eig.info() != Eigen::Success || !(eig.eigenvalues().minCoeff() > 0.0))
    return reject(LoopRejection::CovarianceNotPositive, "covariance is not positive definite");
  const double st = largestSigma(cov.topLeftCorner<3, 3>());
  const double sr = largestSigma(cov.bottomRightCorner<3, 3>());
  if (st > kMaxTranslationSigma)
    return reject(LoopRejection::UncertainTranslation,
                  "translation sigma " + fmt(st) + " m > " + fmt(kMaxTranslationSigma));
  if (sr > kMaxRotationSigma)
    return reject(LoopRejection::UncertainRotation, "rotation sigma " + fmt(sr) + " rad > " + fmt(kMaxRotationSigma));
  cov += honestyTerms(reg, c);
  // Add the floor variances so the information stays finite and no loop becomes rigid.
  cov += floorVariances().asDiagonal();
  setLoopCovariance(lc, cov);
  out.accepted = true;
  return out;
}

const char* toString(LoopRejection rejection) {
  switch (rejection) {
    case LoopRejection::None: return "none";
    case LoopRejection::EmptyCloud: return "empty cloud";
    case LoopRejection::NotConverged: return "not converged";
    case LoopRejection::NonFinite: return "non-finite";
    case LoopRejection::LowFitness: return "low fitness";
    case LoopRejection::HighRmse: return "high rmse";
    case LoopRejection::Degenerate: return "degenerate";
    case LoopRejection::LargeCorrection: return "large correction";
    case LoopRejection::CovarianceNotPositive: return "covariance not positive definite";
    case LoopRejection::UncertainTranslation: return "uncertain translation";
    case LoopRejection::UncertainRotation: return "uncertain rotation";
    case LoopRejection::DriftGate: return "drift gate";
    case LoopRejection::InnovationGate: return "innovation gate";
    case LoopRejection::Ambiguous: return "ambiguous";
    case LoopRejection::Inconsistent: return "pairwise inconsistent";
    case LoopRejection::OptimisationFailed: return "optimisation failed";
    case LoopRejection::OptimisationDiverged: return "optimisation diverged";
  }
  return "unknown";
}

}  // namespace hazmap
