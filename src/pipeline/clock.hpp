#pragma once
// Wall time of the run's stages (SlamTimings, FrameRecord::milliseconds).
#include <chrono>

namespace hazmap::pipeline_detail {

using Clock = std::chrono::steady_clock;
inline double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

}  // namespace hazmap::pipeline_detail
