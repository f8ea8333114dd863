// Scan::imu from an IMU stream (src/sources/imu_attach.hpp).
#include "sources/imu_attach.hpp"

#include <algorithm>

namespace hazmap::sources {

std::pair<double, double> imuSpanOf(const Scan& scan, std::optional<double> previous_stamp) {
  double first = scan.stamp, last = scan.stamp;
  const auto& t = scan.cloud.timestamps;
  if (!t.empty()) {
    const auto [lo, hi] = std::minmax_element(t.begin(), t.end());
    first = std::min(first, *lo), last = std::max(last, *hi);
  }
  if (previous_stamp && *previous_stamp < first) first = *previous_stamp;
  return {first, last};
}

void attachImu(Scan& scan, const std::vector<ImuSample>& samples, std::optional<double> previous_stamp) {
  if (samples.empty()) return;
  const auto [t0, t1] = imuSpanOf(scan, previous_stamp);
  scan.imu = imuSpan(samples, t0, t1);
}

void ImuBuffer::append(const std::vector<ImuSample>& more) {
  for (const ImuSample& sample : more) {
    seen_ = true;
    if (last_time_ && !(sample.time > *last_time_)) {
      ++report_.out_of_order;
      continue;
    }
    if (last_time_ && sample.time - *last_time_ > kImuMaxGap) {
      ++report_.gaps;
      report_.longest_gap = std::max(report_.longest_gap, sample.time - *last_time_);
    }
    last_time_ = sample.time;
    samples_.push_back(sample);
  }
}

void ImuBuffer::attach(Scan& scan, std::optional<double> previous_stamp) {
  attachImu(scan, samples_, previous_stamp);
  const auto byTime = [](const ImuSample& s, double t) { return s.time < t; };
  auto keep = std::lower_bound(samples_.begin(), samples_.end(), scan.stamp, byTime);
  if (keep != samples_.begin()) --keep;
  samples_.erase(samples_.begin(), keep);
}

}  // namespace hazmap::sources
