#pragma once
// The flags every command that reads a recording shares (run, odometry, loops, info, convert):
// which topics of a bag, the sensor's metadata or calibration, deskewing.
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <iostream>
#include <optional>
#include <string>

#include "hazmap/core/class_table.hpp"
#include "hazmap/sources/imu_rotation.hpp"
#include "hazmap/sources/scan_source.hpp"

namespace hazmap::cli {

struct SourceFlags {
  std::string lidar_topic, odom_topic, sensor_metadata, velodyne_calibration, hesai_calibration, sensor, imu_rotation;
  bool no_deskew = false;

  void add(CLI::App& app, bool with_deskew = true) {
    app.add_option("--lidar-topic", lidar_topic,
                   "Bag topic of the LiDAR (PointCloud2, VelodyneScan or Ouster packets); default: the only one");
    app.add_option("--odom-topic", odom_topic,
                   "Bag topic of the wheel odometry (nav_msgs/Odometry); default: the only one, if any");
    app.add_option("--sensor-metadata", sensor_metadata,
                   "Ouster metadata JSON (default: the bag's metadata topic, or the .json next to a .pcap)");
    app.add_option("--velodyne-calibration", velodyne_calibration,
                   "Velodyne calibration YAML (default: the model's factory calibration)");
    app.add_option("--hesai-calibration", hesai_calibration,
                   "Hesai angle-correction CSV (default: the model's built-in angles)");
    app.add_option("--sensor", sensor,
                   "LiDAR model to expect (Hesai: Pandar40P, Pandar64, PandarQT64, PandarQT128, PandarXT16, "
                   "PandarXT32, PandarXT32M; Velodyne: VLP-16, VLP-32C, HDL-32E, VLS-128); default: from the packets");
    app.add_option("--imu-rotation", imu_rotation,
                   "R_lidar_imu of a bag's sensor_msgs/Imu: roll,pitch,yaw (deg), qw,qx,qy,qz, 9 or 16 numbers "
                   "(rotation or 4x4 T_lidar_imu, row-major); default: the IMU's axes are the LiDAR's");
    if (with_deskew)
      app.add_flag("--no-deskew", no_deskew, "Do not motion-compensate scans with per-point times");
  }

  /// `print_notices`: the source's one-line notices (topics not read, …) go to stderr.
  ScanSourceOptions options(std::optional<ClassTable> table = std::nullopt, bool print_notices = false) const {
    ScanSourceOptions o;
    o.lidar_topic = lidar_topic;
    o.odom_topic = odom_topic;
    o.sensor_metadata = sensor_metadata;
    o.velodyne_calibration = velodyne_calibration;
    o.hesai_calibration = hesai_calibration;
    o.sensor = sensor;
    if (!imu_rotation.empty()) o.imu_rotation = parseImuRotation(imu_rotation, "--imu-rotation");
    o.class_table = std::move(table);
    // On a terminal the progress bar's line is cleared first (it is redrawn on the next frame).
    if (print_notices)
      o.notice = [](const std::string& line) {
        std::cerr << (::isatty(STDERR_FILENO) ? "\r\033[K" : "") << "notice: " << line << "\n";
      };
    return o;
  }
};

}  // namespace hazmap::cli
