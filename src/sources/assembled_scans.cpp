// Scans cut from a packet stream, handed on with their IMU span (src/sources/assembled_scans.hpp).
#include "sources/assembled_scans.hpp"

#include <algorithm>

namespace hazmap::sources {

bool AssembledScans::ready() const {
  if (pending_.empty()) return false;
  if (imu_.empty() || pending_.size() >= 2) return true;
  const auto& t = pending_.front().cloud.timestamps;
  return imu_.reaches(t.empty() ? pending_.front().stamp : *std::max_element(t.begin(), t.end()));
}

Scan AssembledScans::pop() {
  Scan scan;
  scan.index = next_index_++;
  scan.stamp = pending_.front().stamp;
  scan.cloud = std::move(pending_.front().cloud);
  scan.cloud.classes.resize(scan.cloud.size(), 0);
  pending_.pop_front();
  if (!imu_.empty()) imu_.attach(scan, previous_stamp_);
  previous_stamp_ = scan.stamp;
  return scan;
}

}  // namespace hazmap::sources
