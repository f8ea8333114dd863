#pragma once
// The run's record of each frame (SlamResult::frames, run.json "tracking") from what the tracker
// did with it.
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/pipeline/slam.hpp"

namespace hazmap::pipeline_detail {

/// Fills `rec` from the tracker's frame `f` (index, stamp and deskew velocity are the caller's).
void recordTracking(FrameRecord& rec, const OdometryFrame& f, OdometryMode mode);
/// Takes the tracker's re-estimate of a lost frame (odometry.recovery.reestimate_lost_frames) into its
/// record: increment, covariance, status; false when it did not change.
bool takeReestimate(FrameRecord& rec, const OdometryFrame& f);

}  // namespace hazmap::pipeline_detail
