#pragma once
// MCAP writer (https://mcap.dev/spec): zstd (or lz4 / uncompressed) chunks, a message index per
// channel after each chunk, and a summary (schemas, channels, statistics, chunk indexes,
// summary offsets) so readers can seek. The file appears only when close() succeeds
// (AtomicFile); a writer destroyed without close() leaves nothing behind.
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace hazmap {

enum class McapCompression { Zstd, Lz4, None };

struct McapWriterOptions {
  std::uint64_t chunk_size = 4u << 20;  ///< uncompressed bytes per chunk before it is closed
  McapCompression compression = McapCompression::Zstd;
  int zstd_level = 3;
  std::string profile = "ros2";
  std::string library = "hazmap";
};

class McapWriter {
 public:
  explicit McapWriter(const std::filesystem::path& path, McapWriterOptions options = {});
  ~McapWriter();
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  /// Registers a schema (e.g. name "sensor_msgs/msg/PointCloud2", encoding "ros2msg").
  std::uint16_t addSchema(const std::string& name, const std::string& encoding, const std::string& data);
  std::uint16_t addChannel(const std::string& topic, std::uint16_t schema_id,
                           const std::string& message_encoding = "cdr");
  /// A CDR channel of a ROS 2 type whose ros2msg definition hazmap knows (see
  /// ros2MessageDefinition); the schema is registered once per type.
  std::uint16_t addRosChannel(const std::string& topic, const std::string& ros2_type);
  /// Appends one message; log times need not be increasing (readers merge by time).
  void write(std::uint16_t channel, std::int64_t log_time_ns, std::span<const std::uint8_t> data,
             std::int64_t publish_time_ns = -1);
  /// Writes the last chunk, the summary and the footer, and moves the file into place.
  void close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The ros2msg text (with its dependencies) of sensor_msgs/msg/PointCloud2, sensor_msgs/msg/Image,
/// nav_msgs/msg/Odometry, geometry_msgs/msg/PoseStamped, std_msgs/msg/String. Throws
/// hazmap::Error for other types.
const std::string& ros2MessageDefinition(const std::string& ros2_type);

}  // namespace hazmap
