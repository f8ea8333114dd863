#pragma once
// A stream of LiDAR scans, whatever the recording: a sequence folder, a bag (PointCloud2,
// VelodyneScan or Ouster packet topics) or a packet capture. Everything downstream (odometry,
// loops, graph, map) consumes this and nothing else, so memory is bounded by the map, not by
// the file.
#include <Eigen/Geometry>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/io/trajectory.hpp"

namespace hazmap {

struct Scan {
  std::size_t index = 0;
  /// Seconds: the scan's reference time. For a spinning LiDAR with per-point times, the middle of
  /// its sweep: an undistorted scan looks on average like the scene seen from there, so the
  /// first scans (before any motion is known to deskew them) and the deskewed ones agree, and
  /// the pose estimated for the scan, its odometry and its ground truth are all at this time.
  double stamp = 0.0;
  LabeledCloud cloud;  ///< sensor frame; per-point absolute times in cloud.timestamps when known
  /// Wheel odometry pose at `stamp` (T_odom_sensor) when the recording has one.
  std::optional<Eigen::Isometry3d> odometry;
  /// Ground-truth pose (T_world_sensor) when the recording has one.
  std::optional<Eigen::Isometry3d> ground_truth;
  /// The recording's named per-point channels (a sequence folder's `channels:`: temperature,
  /// nir_reflectance, …), aligned with cloud's points; the map keeps each one's mean and max.
  std::vector<PointChannel> channels;
  /// The IMU's gravity direction at `stamp` (a sequence folder's gravity.txt) when recorded.
  std::optional<GravitySample> gravity;
  /// The IMU's samples (sensor frame) from the previous scan's stamp (this scan's first point for
  /// the first scan) to this scan's last point, one beyond each end (io/imu.hpp imuSpan); empty
  /// without an IMU stream or where it does not cover that span (then constant velocity).
  std::vector<ImuSample> imu;
};

struct ScanSourceOptions {
  std::string lidar_topic;     ///< empty: the only LiDAR topic, error listing candidates if several
  std::string odom_topic;      ///< empty: the only nav_msgs/Odometry topic, if any
  std::filesystem::path sensor_metadata;     ///< Ouster metadata JSON (else from a bag topic)
  std::filesystem::path velodyne_calibration;  ///< optional calibration YAML (else factory)
  std::filesystem::path hesai_calibration;     ///< optional Hesai angle-correction CSV (else built-in)
  /// The LiDAR model to expect, a Hesai ("Pandar64", "XT32", …) or Velodyne ("VLP-16", …) name;
  /// empty: from the packets. Packets of another model are skipped and counted.
  std::string sensor;
  /// R_lidar_imu: turns a bag's sensor_msgs/Imu samples (gyro and accelerometer) from the IMU's
  /// axes into the LiDAR's (sources/imu_rotation.hpp parses it); unset: the axes are the LiDAR's.
  /// Ouster IMU packets take the metadata's imu_to_sensor_transform instead.
  std::optional<Eigen::Matrix3d> imu_rotation;
  std::optional<ClassTable> class_table;     ///< overrides the recording's
  /// Read the named per-point channels (Scan::channels). Only map assembly uses them: a pass
  /// that only tracks (hazmap run's first) turns this off and skips their files.
  bool read_channels = true;
  /// One-line notices (topics not read, odometry clamped at the recording's ends, bytes a
  /// truncated bag lost); none when unset.
  std::function<void(const std::string&)> notice;
};

class ScanSource {
 public:
  virtual ~ScanSource() = default;
  /// The next scan; nullopt at the end.
  virtual std::optional<Scan> next() = 0;
  /// Number of scans when known without reading them all (sequence folders), else nullopt.
  virtual std::optional<std::size_t> size() const = 0;
  virtual const ClassTable& classTable() const = 0;
  /// Human-readable description, e.g. "rosbag2 (sqlite3) /velodyne_points".
  virtual std::string describe() const = 0;
  /// Whether reread() works: the recording allows random access (sequence folders). Otherwise a
  /// consumer keeps in memory what it needs again.
  virtual bool canReread() const { return false; }
  /// Scan `index`'s cloud again, without disturbing the stream (only when canReread()).
  virtual LabeledCloud reread(std::size_t index) const;
};

/// A sequence folder as a stream: scans in name order, odometry.txt → Scan::odometry, poses.txt
/// → Scan::ground_truth, times.txt (when it has one line per scan) → Scan::stamp, else the index;
/// the `channels:` files → Scan::channels when `read_channels`, imu.txt → Scan::imu.
std::unique_ptr<ScanSource> sequenceScanSource(Sequence sequence, bool read_channels = true);

/// Opens a sequence folder, a bag or a capture. Throws hazmap::Error naming the path.
std::unique_ptr<ScanSource> openScanSource(const std::filesystem::path& path,
                                           const ScanSourceOptions& options = {});

}  // namespace hazmap
