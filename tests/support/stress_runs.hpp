#pragma once
// The trackers compared on the stress sequences (stress_sequences.hpp): hazmap's odometry and
// the KISS-ICP reimplementation (kiss_icp_baseline.hpp), each fed the same scans, timed per scan.
#include <string>
#include <vector>

#include "hazmap/odometry/odometry.hpp"
#include "kiss_icp_baseline.hpp"
#include "stress_sequences.hpp"

namespace hazmap::stress {

struct TrackRun {
  std::vector<Eigen::Isometry3d> poses;  ///< world ← sensor, one per scan
  std::vector<double> ms;                ///< wall time per scan
  std::vector<char> lost;                ///< the tracker said so (hazmap: fallback); the baseline never does
  std::vector<std::string> notes;        ///< hazmap: status, the hypothesis ICP started from
  std::vector<std::string> details;      ///< hazmap: a recovery's trigger, outcome and milliseconds
  std::vector<std::size_t> searches;     ///< hazmap: the frame's work (OdometryFrame::searches)
  std::vector<char> recovered;           ///< hazmap: the recovery ran (a trigger fired)
  double meanMs() const;
  /// The slowest scan the tracker did not call lost, over the median of those (1 when < 2).
  double worstOverMedian() const;
};

TrackRun runHazmap(const Sequence& seq, const ClassTable& table, const OdometryConfig& config);
TrackRun runKiss(const Sequence& seq, const baseline::KissIcpConfig& config = {});

}  // namespace hazmap::stress
