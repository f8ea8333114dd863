#pragma once
// Latency from a scan's last datagram to its pose (issue 33 part 3): `hazmap live` adds one
// sample per frame (the receive time of the scan's newest point to the moment its pose exists)
// and reports the median, the 99th percentile and the largest in run.json (`live.latency_ms`).
// A fixed histogram (0.1 ms bins up to 10 s, beyond it the last bin), so memory stays bounded
// on a long mission.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap {

class FrameLatency {
 public:
  FrameLatency();
  void add(double seconds);
  std::size_t count() const { return count_; }
  /// The q-quantile (0..1) in milliseconds, to the bin's upper edge; 0 without samples.
  double quantileMs(double q) const;
  double maxMs() const { return 1e3 * max_s_; }

 private:
  std::vector<std::uint32_t> bins_;
  std::size_t count_ = 0;
  double max_s_ = 0.0;
};

/// The latency of the most recent frames (GET /status's `latency_ms`): the last `capacity`
/// samples in a ring, so a slow start does not hide a fast present, nor the reverse.
class RecentLatency {
 public:
  explicit RecentLatency(std::size_t capacity = 600);
  void add(double seconds);
  struct Summary {
    std::size_t frames = 0;  ///< samples in the window
    double p50 = 0, p99 = 0, max = 0;  ///< ms; the q-quantile is the ceil(q n)-th smallest
  };
  Summary summary() const;

 private:
  std::vector<double> ring_;
  std::size_t capacity_, next_ = 0;
};

/// The newest per-point time of a scan (s, the clock its points were stamped with: a live
/// stream's receive time); 0 when the scan has no per-point times.
double newestPointTime(const LabeledCloud& scan);
/// Seconds of CLOCK_REALTIME now (the clock a live stream's points are stamped with).
double realtimeNow();

}  // namespace hazmap
