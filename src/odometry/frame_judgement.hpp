#pragma once
// Judging a tracked frame (Odometry::judge, step 4 of Fig. 1): whether ICP from the guess is
// suspect, the directions along which the guess is kept, and when a frame is flagged. The
// failure checks themselves (registrationFailure, correctionOf) are in odometry_checks.hpp.
#include <optional>
#include <string>
#include <vector>

#include "hazmap/odometry/odometry.hpp"

namespace hazmap {

/// A frame's answer in registration space: the pose and its covariance.
struct Estimate {
  Eigen::Isometry3d pose;  ///< in registration space
  Matrix6d covariance;
};

/// Why a registration that passed its checks is still suspect (empty when it is not): the
/// triggers for trying a global registration as well (relocalise_suspect). `only_weak_axis`: the
/// only trigger is a weakly constrained horizontal axis.
std::string suspicion(const RegistrationResult& r, const Eigen::Isometry3d& guess, bool has_prior,
                      double typical_rmse, const OdometryConfig& config, bool& only_weak_axis);
/// The directions along which a tracked frame keeps its guess (ICP's degenerate ones), and
/// their description for the frame's reason.
std::vector<Vector6d> degenerateBasis(const RegistrationResult& r, const OdometryConfig& config);
std::string describeDegenerate(const std::vector<Vector6d>& basis);
/// ICP's answer where it is constrained, the guess along `basis`, with the fallback covariance there.
Estimate keepGuessAlong(const std::vector<Vector6d>& basis, const RegistrationResult& r,
                        const Eigen::Isometry3d& guess, const OdometryConfig& config);
/// What the labels said along a weak axis (Odometry::checkAndRecover): where they placed the
/// frame (`note`, `precise`: to the centimetre), or why they could not (`doubt`).
struct LabelVerdict {
  const std::string& note;
  bool precise;
  const std::string& doubt;
};
/// A tracked or relocalised frame placed along its weak axis by its labels, or flagged for it
/// (weak in ICP's Hessian or in the scan's own surfaces; `source` in the sensor frame, the
/// estimate and ICP's start `guess` in registration space W).
void labelledOrFlagged(OdometryFrame& f, const RegistrationResult& r, Estimate& estimate, const OdometryConfig& config,
                       const LabeledCloud& source, const Eigen::Isometry3d& W, const Eigen::Isometry3d& guess,
                       const LabelVerdict& labels);
/// The weak horizontal axis (world) of the scan's own surfaces at `pose` (world ← sensor), below
/// `ratio` × the strongest: what the scan can observe, whatever the map's normals claim.
std::optional<Eigen::Vector3d> scanWeakHorizontalAxis(const LabeledCloud& source, const Eigen::Isometry3d& pose,
                                                      double ratio);
/// A frame after a flagged one whose answer moved far along that frame's weakest axis is flagged.
void flagAfterFlagged(OdometryFrame& f, const OdometryFrame& previous, const Eigen::Isometry3d& answer,
                      const Eigen::Isometry3d& guess, const Eigen::Isometry3d& W, const OdometryConfig& config);
/// The motion without its roll and pitch: translation and yaw kept.
Eigen::Isometry3d levelled(const Eigen::Isometry3d& T);

}  // namespace hazmap
