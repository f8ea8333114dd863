#pragma once
// Stress sequences from real scans (issue 35), shared by tests/test_tracking_stress.cpp and
// bench/bench_tracking_stress.cpp so that both run the same cases:
//  - frame drop: every k-th scan of a real sequence (the true increment is the composed one);
//  - sudden yaw: from scan `at` on, every scan is turned by a known extra yaw about the sensor's
//    z axis, as if the carrier had turned on the spot between two scans (for a spinning LiDAR a
//    turn about its own axis changes nothing else), so the true increment is known exactly
//    relative to the reference: previous ← current becomes inc · Rz(yaw);
//  - turning: every step turns by the same extra yaw (a constant-velocity guess is right after
//    the first step).
// The reference poses of the KITTI scans are a fine, dense registration chain (they have no
// ground truth: ../shared/data/README.md); those of the Ouster capture are ouster-sdk's SLAM.
#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap::stress {

struct Sequence {
  std::string name;
  std::vector<LabeledCloud> scans;           ///< sensor frame
  std::vector<Eigen::Isometry3d> poses;      ///< reference, world ← sensor
  std::string reference;                     ///< where the poses come from
};

/// KITTI sample scans [first, first + count) of `data`/kitti-semantic-sample (labels mapped by
/// `table` where a label file exists), with a fine registration chain as the reference.
Sequence kittiSequence(const std::filesystem::path& data, const ClassTable& table, int first = 0, int count = 6);
/// The Ouster OS-1-128 capture's three scans with ouster-sdk's poses.
Sequence ousterSequence(const std::filesystem::path& data);

/// Every k-th scan (k >= 1), starting with the first.
Sequence dropFrames(const Sequence& seq, int k);
/// Scans from index `at` on turned by `yaw` (rad) about the sensor's z axis.
Sequence suddenYaw(const Sequence& seq, std::size_t at, double yaw);
/// Scan j turned by j · `yaw_per_step`.
Sequence turning(const Sequence& seq, double yaw_per_step);

/// A scan as the sensor sees it after turning by `yaw` on the spot.
LabeledCloud turned(const LabeledCloud& scan, double yaw);

/// Per-step errors of an estimated trajectory (one pose per scan) against the reference.
struct StepError {
  double translation = 0.0;  ///< m
  double rotation_deg = 0.0;
  double reference_yaw_deg = 0.0;  ///< how far the reference increment turned
};
std::vector<StepError> stepErrors(const Sequence& seq, const std::vector<Eigen::Isometry3d>& estimate);
/// A step is tracked when it is within these of the reference increment.
constexpr double kStepOkTranslation = 0.10;  ///< m
constexpr double kStepOkRotationDeg = 1.0;
inline bool ok(const StepError& e) {
  return e.translation <= kStepOkTranslation && e.rotation_deg <= kStepOkRotationDeg;
}

}  // namespace hazmap::stress
