#pragma once
// The tracking guess after a sudden turn (issue 35): the constant-velocity guess is
// scored against the registration target with a few hundred source points; when it fits clearly
// worse than the starts of the frames before, zero motion, the last translation without its turn,
// an IMU rotation (when one is given), a yaw sweep over the plausible turn around the best of
// them, and, with no motion known yet, a grid of
// horizontal steps are scored too and the best few refined by a short ICP of the sampled points.
// The guess's own refinement comes first: with no motion known yet, a refinement that fits well
// ends the search there (an easy first step costs about what a later one does).
// The full ICP starts from another start only when the guess lies in a wrong basin (its own
// refinement fits clearly worse) or must travel beyond the tracking checks' limits. The score is
// geometric only (nearest target point of any class): the labels act in the ICP that follows,
// so they can only help there.
#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/odometry/motion_hypotheses_config.hpp"
#include "hazmap/registration/registration_target.hpp"

namespace hazmap {

/// What the hypotheses are made of; increments are previous ← current.
struct HypothesisInputs {
  Eigen::Isometry3d guess = Eigen::Isometry3d::Identity();  ///< the odometry's own guess
  const char* guess_name = "constant velocity";
  std::optional<Eigen::Isometry3d> last_increment;  ///< the last estimated increment
  /// previous ← current rotation integrated from an IMU. Nothing feeds it yet: the odometry
  /// receives no IMU; a source that has one passes it here and it competes like the others.
  std::optional<Eigen::Quaterniond> imu_rotation;
};

/// The tracking checks' correction limits (max_correction_*): ICP from the guess that must travel
/// farther fails them; and the platform's plausible motion per frame (recovery.max_*), which
/// bounds the starts tried.
struct HypothesisLimits {
  double max_translation = 1.0;  ///< m
  double max_rotation = 0.2;     ///< rad
  double plausible_translation = 4.0;  ///< m
  double plausible_rotation = 1.6;     ///< rad
};

struct HypothesisChoice {
  Eigen::Isometry3d increment = Eigen::Isometry3d::Identity();  ///< where ICP starts
  std::string name;            ///< the winning hypothesis ("constant velocity", "yaw sweep +40.0 deg", ...)
  bool searched = false;       ///< the guess fitted poorly: the other hypotheses were scored
  bool replaced = false;       ///< another hypothesis replaced the guess
  double guess_score = 0.0;    ///< the guess's score (share of sampled points near a target point)
  double score = 0.0;          ///< the chosen start's
  int scored = 0;              ///< hypotheses scored
  /// Nearest-target searches made (each scored or refined sample point once per pass): the work,
  /// independent of the machine (tests/test_tracking_stress.cpp compares it across frames).
  std::size_t searches = 0;
  double ms = 0.0;
};

/// Share (0..1, soft) of the sampled source points that land near a target point at `pose`
/// (registration space ← source): each point within the score gate counts 1 − d²/gate².
double hypothesisScore(const LabeledCloud& sample, const RegistrationTarget& target, const Eigen::Isometry3d& pose);

class MotionHypotheses {
 public:
  /// `previous` = registration space ← the previous frame; `icp` the tracking ICP's settings
  /// (the best starts are refined by a short ICP of the sampled points). Deterministic.
  HypothesisChoice choose(const LabeledCloud& source, const RegistrationTarget& target,
                          const Eigen::Isometry3d& previous, const HypothesisInputs& in,
                          const ClassTable& classes, const RegistrationConfig& icp,
                          const HypothesisLimits& limits, const MotionHypothesisConfig& config);

 private:
  double typical_ = 0.0;  ///< running score of the chosen starts (0 = no frame yet)
};

}  // namespace hazmap
