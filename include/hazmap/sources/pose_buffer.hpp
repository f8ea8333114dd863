#pragma once
// Poses that arrive at their own rate (wheel odometry at 50 Hz, ground truth) looked up at a
// scan's time: SE(3) interpolation between the two poses around it (slerp of the rotation, lerp
// of the translation), as tf2 does between two transforms.
#include <Eigen/Geometry>
#include <deque>
#include <optional>

namespace hazmap {

/// Interpolates T_a and T_b at fraction s ∈ [0, 1]: slerp on the rotation, lerp on the translation.
Eigen::Isometry3d interpolatePose(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b, double s);

class PoseBuffer {
 public:
  /// Appends a pose; stamps must not decrease (an older one is dropped and false returned).
  bool push(double stamp, const Eigen::Isometry3d& pose);
  /// True when a pose at or after `stamp` has arrived, so `at(stamp)` will not change.
  bool covers(double stamp) const { return !poses_.empty() && poses_.back().stamp >= stamp; }
  bool empty() const { return poses_.empty(); }
  /// The pose at `stamp`: interpolated inside the buffered span, the nearest end outside it
  /// (`clamped` says so). nullopt when the buffer is empty.
  std::optional<Eigen::Isometry3d> at(double stamp, bool* clamped = nullptr) const;
  /// Drops poses no longer needed for lookups at `stamp` or later (keeps the one before it).
  void dropBefore(double stamp);
  std::size_t size() const { return poses_.size(); }

 private:
  struct Stamped {
    double stamp;
    Eigen::Isometry3d pose;
  };
  std::deque<Stamped> poses_;
};

}  // namespace hazmap
