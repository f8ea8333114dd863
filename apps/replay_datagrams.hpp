#pragma once
// What `hazmap replay` sends, in order: the UDP datagrams of a capture, or the LiDAR packets of a
// bag (VelodyneScan, PandarScan, Ouster lidar and IMU packet topics) addressed to the sensor's
// standard port (Velodyne and Hesai 2368, Ouster 7502 and its IMU 7503), each at its stamp.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>

namespace hazmap::cli {

struct ReplayDatagram {
  std::int64_t time_ns = 0;
  std::uint16_t port = 0;
  std::span<const std::uint8_t> payload;  ///< valid until the next call
};

class ReplayDatagrams {
 public:
  virtual ~ReplayDatagrams() = default;
  virtual bool next(ReplayDatagram& datagram) = 0;
};

/// A capture or a bag; throws hazmap::Error naming the path when it is neither, or a bag has no
/// LiDAR packet topic.
std::unique_ptr<ReplayDatagrams> openReplayDatagrams(const std::filesystem::path& path);

}  // namespace hazmap::cli
