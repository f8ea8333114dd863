#pragma once
// gravity.txt of a sequence folder: what an IMU's accelerometers (an AHRS) say about the
// direction of gravity at each scan. A crawler moves slowly, so the specific force its
// accelerometers measure is gravity alone; it fixes roll and pitch absolutely (yaw stays free).
//
// One line per scan, in scan order, '#' comments and blank lines allowed:
//   time  dx dy dz  sigma_deg
// time: s (the scan's time); (dx, dy, dz): unit vector pointing DOWN (towards the earth's
// centre) in the sensor frame; sigma_deg: standard deviation of the direction, ° per axis (the
// roll and pitch accuracy of the AHRS). docs/formats.md.
#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <vector>

namespace hazmap {

struct GravitySample {
  double time = 0.0;                                      ///< s
  Eigen::Vector3d down = Eigen::Vector3d(0.0, 0.0, -1.0);  ///< unit vector, sensor frame
  double sigma_deg = 0.0;                                 ///< ° per axis, > 0
  double sigmaRad() const { return sigma_deg * 3.14159265358979323846 / 180.0; }
};

/// Reads gravity.txt. Throws hazmap::Error("<path>:<line>: ...") for a wrong column count, a
/// non-number, NaN/inf, a direction that is not a unit vector (|d| off 1 by more than 1e-3), a
/// σ that is not positive, and ("<path>: ...") for a count other than `scans` (when given).
std::vector<GravitySample> readGravityFile(const std::filesystem::path& path,
                                           std::optional<std::size_t> scans = std::nullopt);

/// Writes gravity.txt atomically (shortest round-trip numbers, so write → read is exact).
void writeGravityFile(const std::filesystem::path& path, const std::vector<GravitySample>& samples);

}  // namespace hazmap
