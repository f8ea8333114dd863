#include "hazmap/sources/pose_buffer.hpp"

#include <algorithm>

namespace hazmap {

Eigen::Isometry3d interpolatePose(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b, double s) {
  const Eigen::Quaterniond q_a(T_a.linear()), q_b(T_b.linear());
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q_a.slerp(s, q_b).normalized().toRotationMatrix();
  T.translation() = (1.0 - s) * T_a.translation() + s * T_b.translation();
  return T;
}

bool PoseBuffer::push(double stamp, const Eigen::Isometry3d& pose) {
  if (!poses_.empty() && stamp < poses_.back().stamp) return false;
  poses_.push_back({stamp, pose});
  return true;
}

std::optional<Eigen::Isometry3d> PoseBuffer::at(double stamp, bool* clamped) const {
  if (clamped) *clamped = false;
  if (poses_.empty()) return std::nullopt;
  const auto after = std::lower_bound(poses_.begin(), poses_.end(), stamp,
                                      [](const Stamped& p, double t) { return p.stamp < t; });
  if (after == poses_.end() || (after == poses_.begin() && after->stamp > stamp)) {
    if (clamped) *clamped = true;
    return after == poses_.end() ? poses_.back().pose : poses_.front().pose;
  }
  if (after->stamp == stamp || after == poses_.begin()) return after->pose;
  const auto before = std::prev(after);
  const double s = (stamp - before->stamp) / (after->stamp - before->stamp);
  return interpolatePose(before->pose, after->pose, s);
}

void PoseBuffer::dropBefore(double stamp) {
  while (poses_.size() >= 2 && poses_[1].stamp <= stamp) poses_.pop_front();
}

}  // namespace hazmap
