#include "hazmap/odometry/frame_history.hpp"

#include <algorithm>

#include "hazmap/core/retire_oldest.hpp"

namespace hazmap {

void FrameHistory::keepNewest(std::size_t n) {
  keep_ = std::max<std::size_t>(n, 1);
  trim();
}

void FrameHistory::push(OdometryFrame f) {
  kept_.push_back(std::move(f));
  trim();
}

void FrameHistory::trim() {
  first_kept_ += retireOldest(kept_, keep_, [&](const OdometryFrame& f) { past_.push_back({f.stamp, f.status, f.pose}); });
}

}  // namespace hazmap
