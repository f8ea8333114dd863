#pragma once
// Shared by the bag fuzz targets: read every message of a reader and decode it by its type,
// checking the promises the readers make (log-time order, topics from topics(), loss counts
// consistent) and that decoded clouds hold only finite points with aligned channels.
#include <cstdlib>

#include "fuzz_input.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/ros_messages.hpp"

namespace hazmap::fuzz {

inline void decodeByType(const BagMessage& m) {
  const auto& type = m.topic->type;
  const Serialization s = m.topic->serialization;
  try {
    if (type == "sensor_msgs/msg/PointCloud2") checkCloud(pointCloud2ToCloud(decodePointCloud2(m.data, s, "f"), "f"));
    if (type == "nav_msgs/msg/Odometry") {
      if (!decodeOdometry(m.data, s, "f").pose.matrix().allFinite()) std::abort();
    }
    if (type == "sensor_msgs/msg/Image") decodeImage(m.data, s, "f");
    if (type == "velodyne_msgs/msg/VelodyneScan")
      for (const auto& p : decodeVelodyneScan(m.data, s, "f").packets)
        if (p.data.size() != 1206) std::abort();
    if (type == "ouster_ros/msg/PacketMsg") decodeOusterPacket(m.data, s, "f");
    if (type == "std_msgs/msg/String") decodeString(m.data, s, "f");
  } catch (const Error&) {
  }
}

inline void drain(MessageReader& reader) {
  const auto& topics = reader.topics();
  BagMessage m;
  std::int64_t last = INT64_MIN;
  std::size_t n = 0;
  while (reader.next(m) && n++ < 100000) {
    if (m.topic < topics.data() || m.topic >= topics.data() + topics.size()) std::abort();
    if (m.log_time_ns < last) std::abort();
    last = m.log_time_ns;
    decodeByType(m);
  }
  if (reader.loss().chunks_skipped > reader.loss().notices.size()) std::abort();
}

}  // namespace hazmap::fuzz
