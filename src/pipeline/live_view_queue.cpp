#include "pipeline/live_view_queue.hpp"

namespace hazmap::pipeline_detail {

std::size_t scanBytes(const LabeledCloud& c) {
  return c.size() * (sizeof(Eigen::Vector3f) + sizeof(ClassId)) + c.property.size() * sizeof(float) +
         c.intensity.size() * sizeof(float) + c.timestamps.size() * sizeof(double);
}

bool LiveViewQueue::reserve(std::size_t bytes) {
  if (bytes_ + bytes > budget_) return false;
  bytes_ += bytes;
  return true;
}

void LiveViewQueue::push(LiveViewItem item) {
  if (item.correction) {
    for (LiveViewItem& queued : items_) {
      if (!queued.correction) continue;
      queued.correction = false;
      std::vector<Eigen::Isometry3d>().swap(queued.corrected);
      ++superseded_;
    }
    std::erase_if(items_, [](const LiveViewItem& i) { return !i.has_frame && !i.correction; });
  }
  items_.push_back(std::move(item));
}

std::deque<LiveViewItem> LiveViewQueue::take() {
  std::deque<LiveViewItem> out;
  out.swap(items_);
  return out;
}

std::size_t LiveViewQueue::queuedPoses() const {
  std::size_t n = 0;
  for (const LiveViewItem& i : items_) n += i.corrected.size();
  return n;
}

}  // namespace hazmap::pipeline_detail
