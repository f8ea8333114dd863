#pragma once
// The tracker's frames (Odometry::frames): every frame in full by default. On a long mission the
// pipeline keeps only the newest in full and the older ones as stamp, status and pose, all that
// tracking reads of them (issue 33: a full record is ~1.9 kB, ~70 MB an hour at 10 scans/s).
#include <Eigen/Geometry>
#include <cstddef>
#include <limits>
#include <vector>

#include "hazmap/odometry/odometry_frame.hpp"

namespace hazmap {

class FrameHistory {
 public:
  std::size_t size() const { return first_kept_ + kept_.size(); }
  bool empty() const { return size() == 0; }
  /// From now on the newest `n` frames (at least one) are kept in full.
  void keepNewest(std::size_t n);
  void push(OdometryFrame f);
  const OdometryFrame& back() const { return kept_.back(); }
  OdometryFrame& back() { return kept_.back(); }
  /// Frame i in full; std::out_of_range unless firstKept() ≤ i < size().
  OdometryFrame& full(std::size_t i) { return kept_.at(i - first_kept_); }
  const OdometryFrame& full(std::size_t i) const { return kept_.at(i - first_kept_); }
  const Eigen::Isometry3d& pose(std::size_t i) const { return i < first_kept_ ? past_.at(i).pose : full(i).pose; }
  void setPose(std::size_t i, const Eigen::Isometry3d& pose) { (i < first_kept_ ? past_.at(i).pose : full(i).pose) = pose; }
  FrameStatus status(std::size_t i) const { return i < first_kept_ ? past_.at(i).status : full(i).status; }
  double stamp(std::size_t i) const { return i < first_kept_ ? past_.at(i).stamp : full(i).stamp; }
  /// The frames kept in full, frames firstKept() … size() − 1: all of them unless keepNewest().
  const std::vector<OdometryFrame>& kept() const { return kept_; }
  std::size_t firstKept() const { return first_kept_; }

 private:
  void trim();

  struct Past {
    double stamp;
    FrameStatus status;
    Eigen::Isometry3d pose;
  };
  std::vector<Past> past_;           // frames 0 … first_kept_ − 1
  std::vector<OdometryFrame> kept_;  // frames first_kept_ … size() − 1
  std::size_t first_kept_ = 0;
  std::size_t keep_ = std::numeric_limits<std::size_t>::max();
};

}  // namespace hazmap
