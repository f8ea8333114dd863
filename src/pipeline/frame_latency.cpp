#include "hazmap/pipeline/frame_latency.hpp"

#include <time.h>

#include <algorithm>
#include <cmath>

namespace hazmap {

namespace {
constexpr double kBinSeconds = 1e-4;
constexpr std::size_t kBins = 100'000;  // 10 s
}  // namespace

FrameLatency::FrameLatency() : bins_(kBins, 0) {}

void FrameLatency::add(double seconds) {
  if (!std::isfinite(seconds)) return;
  seconds = std::max(0.0, seconds);
  const auto bin = static_cast<std::size_t>(std::min(seconds / kBinSeconds, double(kBins - 1)));
  ++bins_[bin];
  ++count_;
  max_s_ = std::max(max_s_, seconds);
}

double FrameLatency::quantileMs(double q) const {
  if (count_ == 0) return 0.0;
  const auto rank = static_cast<std::size_t>(std::ceil(std::clamp(q, 0.0, 1.0) * double(count_)));
  std::size_t seen = 0;
  for (std::size_t b = 0; b < kBins; ++b) {
    seen += bins_[b];
    if (seen >= std::max<std::size_t>(rank, 1)) return std::min(1e3 * double(b + 1) * kBinSeconds, maxMs());
  }
  return maxMs();
}

RecentLatency::RecentLatency(std::size_t capacity) : capacity_(std::max<std::size_t>(capacity, 1)) {
  ring_.reserve(capacity_);
}

void RecentLatency::add(double seconds) {
  if (!std::isfinite(seconds)) return;
  seconds = std::max(0.0, seconds);
  if (ring_.size() < capacity_) ring_.push_back(seconds);
  else ring_[next_] = seconds;
  next_ = (next_ + 1) % capacity_;
}

RecentLatency::Summary RecentLatency::summary() const {
  Summary s;
  s.frames = ring_.size();
  if (ring_.empty()) return s;
  std::vector<double> sorted = ring_;
  std::sort(sorted.begin(), sorted.end());
  const auto at = [&](double q) {
    const auto rank = static_cast<std::size_t>(std::ceil(q * double(sorted.size())));
    return 1e3 * sorted[std::clamp<std::size_t>(rank, 1, sorted.size()) - 1];
  };
  s.p50 = at(0.5);
  s.p99 = at(0.99);
  s.max = 1e3 * sorted.back();
  return s;
}

double newestPointTime(const LabeledCloud& scan) {
  if (scan.timestamps.empty()) return 0.0;
  return *std::max_element(scan.timestamps.begin(), scan.timestamps.end());
}

double realtimeNow() {
  timespec now;
  ::clock_gettime(CLOCK_REALTIME, &now);
  return double(now.tv_sec) + 1e-9 * double(now.tv_nsec);
}

}  // namespace hazmap
