#pragma once
// Giving each scan the IMU samples over its time span (Scan::imu), whatever the source.
#include <optional>
#include <vector>

#include "hazmap/io/imu.hpp"
#include "hazmap/sources/scan_source.hpp"

namespace hazmap::sources {

/// The span Scan::imu covers: from `previous_stamp` (else the scan's first point, else its
/// stamp) to the scan's last point (else its stamp).
std::pair<double, double> imuSpanOf(const Scan& scan, std::optional<double> previous_stamp);

/// Sets scan.imu from `samples` (time order) over imuSpanOf.
void attachImu(Scan& scan, const std::vector<ImuSample>& samples, std::optional<double> previous_stamp);

/// An IMU stream read piece by piece (a capture's or a bag's IMU packets or messages): keeps the
/// samples a scan still needs, drops out-of-order ones, counts gaps.
class ImuBuffer {
 public:
  void append(const std::vector<ImuSample>& more);
  bool empty() const { return samples_.empty() && !seen_; }
  /// Whether the stream has reached `time` (a sample at or after it).
  bool reaches(double time) const { return !samples_.empty() && samples_.back().time >= time; }
  /// Sets scan.imu, then forgets the samples before the scan's stamp (the next span starts there).
  void attach(Scan& scan, std::optional<double> previous_stamp);
  /// The stream's cleaning report as one notice line naming `where` ("" when clean).
  std::string notice(const std::string& where) const { return describe(report_, where); }

 private:
  std::vector<ImuSample> samples_;
  ImuStreamReport report_;
  std::optional<double> last_time_;
  bool seen_ = false;
};

}  // namespace hazmap::sources
