#pragma once
// One tracked frame as the tracker records it (Odometry::addFrame): its pose, increment and
// covariance, the path that produced them (FrameStatus) and the registration behind them.
#include <Eigen/Geometry>
#include <cstddef>
#include <string>

#include "hazmap/core/se3.hpp"
#include "hazmap/registration/global_registration.hpp"
#include "hazmap/registration/registration.hpp"

namespace hazmap {

enum class FrameStatus {
  First,        ///< the first frame (pose = initial pose)
  Tracked,      ///< ICP from the guess used
  Degenerate,   ///< tracked, but the guess kept along ICP's degenerate directions
  Relocalised,  ///< global registration (no guess), verified by ICP, used
  Fallback,     ///< nothing verified: the guessed increment was used; the frame is flagged
};
/// "first", "tracked", "degenerate", "relocalised", "fallback".
const char* toString(FrameStatus status);
/// One line for people, e.g. "relocalised: global registration verified by ICP".
const char* describe(FrameStatus status);
/// A frame whose pose no registration fully vouches for: fallback (nothing verified), or
/// degenerate (along some direction the pose is the guess's, not the registration's).
inline bool isFlagged(FrameStatus status) { return status == FrameStatus::Fallback || status == FrameStatus::Degenerate; }

/// The global registration tried on a frame (issue 19).
struct GlobalAttempt {
  bool tried = false;
  std::string trigger;   ///< why it was tried
  GlobalStatus status = GlobalStatus::NoConsensus;
  std::string outcome;   ///< "used", or why not (the global reason or the failed verification)
  double score = 0.0, second_best_score = 0.0;
  double milliseconds = 0.0;  ///< target preparation + global registration + verification
  /// The whole map (keyframes) was tried after several failed frames (kidnapped robot); `status`,
  /// `score` and `outcome` are then that attempt's.
  bool whole_map = false;
};

struct OdometryFrame {
  std::size_t index = 0;
  double stamp = 0.0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();       ///< world ← sensor
  Eigen::Isometry3d increment = Eigen::Isometry3d::Identity();  ///< previous ← current
  Eigen::Isometry3d guess = Eigen::Isometry3d::Identity();      ///< guessed increment
  /// Covariance of `increment` (left perturbation, translation first, previous frame).
  Matrix6d covariance = Matrix6d::Zero();
  FrameStatus status = FrameStatus::First;
  std::string reason;  ///< why the frame fell back / was degenerate
  bool wheel_guess = false;  ///< the guess came from wheel odometry (else constant velocity)
  bool imu_guess = false;    ///< the guess's rotation is the gyro's (an IMU stream)
  /// The motion hypothesis ICP started from when it replaced the guess (motion_hypotheses), else empty.
  std::string guess_hypothesis;
  RegistrationResult registration;  ///< the ICP whose answer was used (or the failed one)
  GlobalAttempt global;
  std::size_t scan_points = 0, source_points = 0, map_points = 0;
  /// Wall times: preprocess = the scan's crop and downsampling (frame to map it runs beside the
  /// local map's target build); registration = the rest of the frame (target, ICP, checks, map
  /// update) = total − preprocess.
  double preprocess_ms = 0.0, registration_ms = 0.0, total_ms = 0.0;
  /// The frame's work, independent of the machine: nearest-target searches of the motion
  /// hypotheses and of every ICP run for it (tracking and the recovery's starts; a global
  /// registration's feature work is not counted: global.tried says it ran).
  std::size_t searches = 0;
};

}  // namespace hazmap
