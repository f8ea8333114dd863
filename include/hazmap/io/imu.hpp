#pragma once
// An IMU's raw samples: gyro and accelerometer, as a stream in time (a sequence folder's
// imu.txt, a bag's sensor_msgs/Imu topic, Ouster IMU packets).
//
// imu.txt: one sample per line, in time order, '#' comments and blank lines allowed:
//   time  wx wy wz  ax ay az
// time: s, on the clock of the scans (times.txt); (wx, wy, wz): angular velocity, rad/s;
// (ax, ay, az): specific force, m/s² (an IMU at rest reads +9.81 up). Both in the LiDAR's
// sensor frame (the frame of the scans): a recording rotates its IMU's axes by T_lidar_imu
// before writing. docs/formats.md.
#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

namespace hazmap {

struct ImuSample {
  double time = 0.0;                               ///< s
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();  ///< rad/s
  Eigen::Vector3d accel = Eigen::Vector3d::Zero(); ///< m/s², specific force
};

/// The longest interval between two IMU samples that is integrated as measured (s); a longer
/// gap leaves the scans over it without IMU (constant velocity, as without an IMU).
inline constexpr double kImuMaxGap = 0.05;

/// What cleaning an IMU stream found (cleanImuStream).
struct ImuStreamReport {
  std::size_t out_of_order = 0;  ///< samples dropped: time not after the previous kept one
  std::size_t gaps = 0;          ///< intervals longer than the gap limit (bridged downstream)
  double longest_gap = 0.0;      ///< s
};

/// Drops samples whose time does not increase (a recorder's reordering, a duplicated message)
/// and counts the gaps longer than `max_gap` s. Never throws: a poor IMU stream is warned about
/// and bridged (constant velocity where it has no sample), not an error.
ImuStreamReport cleanImuStream(std::vector<ImuSample>& samples, double max_gap);
/// One line for a notice ("" when the stream was clean), naming `where`.
std::string describe(const ImuStreamReport& report, const std::string& where);

/// Reads imu.txt. Throws hazmap::Error("<path>:<line>: ...") for a wrong column count, a
/// non-number or NaN/inf. Out-of-order times are kept (cleanImuStream drops them with a notice).
std::vector<ImuSample> readImuFile(const std::filesystem::path& path);

/// Writes imu.txt atomically (shortest round-trip numbers, so write → read is exact).
void writeImuFile(const std::filesystem::path& path, const std::vector<ImuSample>& samples);

/// The samples with time in [t0, t1] plus one on each side when there is one, so that the span
/// can be integrated end to end; empty unless they cover [t0, t1] without a gap longer than
/// kImuMaxGap (a stream that does not cover a scan leaves it to constant velocity). `samples`
/// in time order.
std::vector<ImuSample> imuSpan(const std::vector<ImuSample>& samples, double t0, double t1);

}  // namespace hazmap
