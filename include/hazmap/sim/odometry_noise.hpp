#pragma once
// What the crawler's track encoders report between two scans. Planar, as encoders are: no
// change in z, roll or pitch. All defaults are part of the simulator's specification (issue 3),
// fixed before any SLAM result existed; do not tune them to a method.
#include <Eigen/Geometry>
#include <vector>

#include "hazmap/sim/random.hpp"
#include "hazmap/sim/route.hpp"

namespace hazmap::sim {

struct OdometryNoiseConfig {
  double forward_scale_sigma = 0.05;  ///< forward distance × (1 + N(0, σ))
  double lateral_sigma = 0.03;        ///< m, lateral N(0, σ) per frame
  double yaw_sigma_deg = 0.25;        ///< °, yaw N(0, σ) per frame
  double skid_fraction = 0.05;        ///< yaw skid N(0, fraction × |frame's turn|)
  double slip_probability = 0.08;     ///< per frame: the encoders report extra forward travel...
  double slip_min = 0.2;              ///< ...of U(slip_min, slip_max) m that did not happen
  double slip_max = 0.5;
};

/// The crawler's bad days (issue 19): true motion the route did not plan and the encoders did not
/// see. All off by default (the defaults above stay the paper's set-up); the `worst-day` preset
/// of the simulator config turns them on. Draws use their own random stream, so switching them
/// on never changes the sensor noise of a frame.
struct CrawlerUpsetConfig {
  double yaw_kick_probability = 0.0;  ///< per frame: the crawler spins on debris...
  double yaw_kick_min_deg = 10.0;     ///< ...by U(min, max) degrees, either way, unseen by the
  double yaw_kick_max_deg = 45.0;     ///< encoders (the heading stays turned)
  double drop_probability = 0.0;      ///< per frame: the scan is lost (never two in a row), so
                                      ///< the next increment spans two triggers
};

/// Applies the upsets to the route's scan triggers: drops lost scans (never the first, never two
/// in a row) and turns each remaining sample's heading by the kicks so far. Returns each
/// remaining frame's own kick (rad, 0 for most). Frame i's draws use Rng(seed, Upset, i) of the
/// trigger's index before dropping.
std::vector<double> applyCrawlerUpsets(std::vector<RouteSample>& samples, const CrawlerUpsetConfig& config,
                                       std::uint64_t seed);

/// A planar motion between two scans, in the frame of the first one.
struct PlanarIncrement {
  double forward = 0.0;  ///< m along the robot's x
  double lateral = 0.0;  ///< m along the robot's y
  double yaw = 0.0;      ///< rad
  /// The increment as a planar pose.
  Eigen::Isometry3d toPose() const;
  /// The planar part of T_a⁻¹ T_b (x, y, yaw of the relative pose).
  static PlanarIncrement between(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b);
};

/// One frame of encoder odometry: the true increment corrupted as the config says. `slipped`
/// (optional) tells whether a track slip happened.
PlanarIncrement noisyIncrement(const PlanarIncrement& truth, const OdometryNoiseConfig& config,
                               Rng& rng, bool* slipped = nullptr);

/// Accumulated odometry for a sequence of true poses: starts at poses[0], then composes one
/// noisy increment per frame; frame i uses Rng(seed, Odometry, i). The result is planar in the
/// start pose's plane. `unseen_yaw` (optional, rad per frame) is true rotation the encoders
/// missed (yaw kicks): it is taken out of the increment before the noise.
std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> accumulateOdometry(
    const std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>& truth,
    const OdometryNoiseConfig& config, std::uint64_t seed, std::vector<bool>* slipped = nullptr,
    const std::vector<double>* unseen_yaw = nullptr);

}  // namespace hazmap::sim
