#include "hazmap/odometry/frame_history.hpp"

#include <algorithm>

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
  if (kept_.size() <= keep_) return;
  const auto drop = static_cast<std::ptrdiff_t>(kept_.size() - keep_);
  for (auto f = kept_.begin(); f != kept_.begin() + drop; ++f) past_.push_back({f->stamp, f->status, f->pose});
  kept_.erase(kept_.begin(), kept_.begin() + drop);
  first_kept_ += static_cast<std::size_t>(drop);
}

}  // namespace hazmap
