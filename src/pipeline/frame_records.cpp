#include "pipeline/frame_records.hpp"

#include "pipeline/edge_noise.hpp"

namespace hazmap::pipeline_detail {

void recordTracking(FrameRecord& rec, const OdometryFrame& f, OdometryMode mode) {
  rec.T_prev_curr = f.increment;
  rec.covariance = f.covariance;
  rec.icp_used = f.status != FrameStatus::Fallback;
  rec.status = f.status;
  rec.fallback_reason = f.reason;
  rec.fitness = f.registration.fitness;
  rec.rmse = f.registration.inlier_rmse;
  rec.iterations = f.registration.iterations;
  rec.stalled = (f.status == FrameStatus::Tracked || f.status == FrameStatus::Degenerate) &&
                !f.registration.converged && f.registration.termination == Termination::MaxIterations;
  rec.points = f.source_points;
  rec.guess_covariance = guessCovariance(f, mode);
}

bool takeReestimate(FrameRecord& rec, const OdometryFrame& f) {
  if (f.increment.matrix() == rec.T_prev_curr.matrix() && f.status == rec.status) return false;
  rec.T_prev_curr = f.increment;
  rec.covariance = f.covariance;
  rec.status = f.status;
  rec.icp_used = f.status != FrameStatus::Fallback;
  rec.fallback_reason = f.reason;
  return true;
}

}  // namespace hazmap::pipeline_detail
