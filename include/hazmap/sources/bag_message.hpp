#pragma once
// The container layer of the sources stage: ROS 2 bags (rosbag2 sqlite3 folders, MCAP files) and
// ROS 1 bags (format 2.0) all read as one stream of serialized messages in log-time order.
// Decoding a message's bytes is ros_messages.hpp's job; turning messages into scans is
// scan_source.hpp's.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace hazmap {

/// How a message's bytes are serialized: ROS 2 CDR (with its 4-byte encapsulation header) or
/// ROS 1's little-endian, unaligned serialization. Other (an MCAP channel in json, protobuf,
/// …): listed by topics(), never decodable by ros_messages.hpp.
enum class Serialization { Cdr, Ros1, Other };

struct TopicInfo {
  std::string name;                   ///< e.g. "/velodyne_points"
  /// Always the ROS 2 spelling, e.g. "sensor_msgs/msg/PointCloud2", also for ROS 1 bags (whose
  /// "sensor_msgs/PointCloud2" is respelled), so one comparison serves every container.
  std::string type;
  Serialization serialization = Serialization::Cdr;
  std::uint64_t message_count = 0;    ///< 0 when the container does not say and was not scanned
  std::string definition;             ///< message definition text when the container has one
};

/// One message. `data` stays valid until the next call to MessageReader::next().
struct BagMessage {
  const TopicInfo* topic = nullptr;
  std::int64_t log_time_ns = 0;      ///< recorder's receive time
  std::span<const std::uint8_t> data;
};

/// What a reader could not read (a recorder killed mid-write, a corrupt chunk). Filled while
/// reading: complete once next() has returned false. Nothing in here was ever yielded.
struct BagLoss {
  std::uint64_t bytes_unread = 0;     ///< bytes after the last complete record (truncated file)
  std::uint64_t chunks_skipped = 0;   ///< corrupt chunks (CRC mismatch, bad compression, …), skipped whole
  std::vector<std::string> notices;   ///< one line each, naming the file and the offset
};

class MessageReader {
 public:
  virtual ~MessageReader() = default;
  /// Every topic of the container (from its summary/metadata/connection records).
  virtual const std::vector<TopicInfo>& topics() const = 0;
  /// Next message in log-time order among the selected topics; false at the end.
  virtual bool next(BagMessage& message) = 0;
  /// Restricts next() to these topic names (empty = all). Call before the first next().
  virtual void selectTopics(const std::vector<std::string>& names) = 0;
  /// Start and end log time over all messages (ns); {0, 0} when unknown.
  virtual std::pair<std::int64_t, std::int64_t> timeRange() const = 0;
  const BagLoss& loss() const { return loss_; }

 protected:
  BagLoss loss_;
};

/// True if `path` is a bag this stage reads: an .mcap file, a rosbag2 folder (metadata.yaml
/// with .db3 or .mcap storage) or a ROS 1 .bag file. Decided by content, not only by name.
bool isBag(const std::filesystem::path& path);
/// Opens any bag. Throws hazmap::Error naming the path when it is none of the above.
std::unique_ptr<MessageReader> openBag(const std::filesystem::path& path);

}  // namespace hazmap
