// What a run returns (SlamResult, FrameRecord): summaries and the scans as tracking saw them.
#include "hazmap/pipeline/slam.hpp"

namespace hazmap {

TrackingCounts countTracking(const std::vector<FrameRecord>& frames) {
  TrackingCounts c;
  for (const auto& f : frames) {
    c.relocalised += f.status == FrameStatus::Relocalised;
    c.fallback += f.status == FrameStatus::Fallback;
  }
  c.tracked = frames.size() - c.relocalised - c.fallback;
  return c;
}

double SlamResult::framesPerSecond() const {
  return timings.total_s > 0 ? static_cast<double>(frames.size()) / timings.total_s : 0.0;
}

void redoDeskew(LabeledCloud& cloud, const FrameRecord& record) {
  if (record.deskew_velocity) deskewScan(cloud, *record.deskew_velocity, record.stamp);
}

}  // namespace hazmap
