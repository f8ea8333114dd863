#pragma once
// The concrete readers behind openBag(), for the sources stage's own use and its tests.
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "hazmap/sources/bag_message.hpp"

namespace hazmap::sources {

/// A rosbag2 folder (metadata.yaml + .db3 or .mcap files), or one .db3 file.
std::unique_ptr<MessageReader> openRosbag2(const std::filesystem::path& path);
/// One rosbag2 sqlite3 storage file.
std::unique_ptr<MessageReader> openDb3(const std::filesystem::path& file);
/// One MCAP file.
std::unique_ptr<MessageReader> openMcap(const std::filesystem::path& file);
/// One ROS 1 bag (format 2.0).
std::unique_ptr<MessageReader> openRos1Bag(const std::filesystem::path& file);
/// Several readers as one stream in log-time order (a split rosbag2); topics merged by name.
std::unique_ptr<MessageReader> mergeReaders(std::vector<std::unique_ptr<MessageReader>> readers);

/// "sensor_msgs/PointCloud2" → "sensor_msgs/msg/PointCloud2"; ROS 2 names are kept.
std::string ros2TypeName(const std::string& type);
/// "cdr" / "" → Cdr, "ros1" → Ros1, anything else → Other.
Serialization serializationFromName(const std::string& name);

inline constexpr unsigned char kMcapMagic[8] = {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'};
inline constexpr char kRos1Magic[] = "#ROSBAG V2.0\n";

}  // namespace hazmap::sources
