#pragma once
// A simulated scan as a VLP-16 sends it (`hazmap simulate --format pcap`): 1206-byte data packets
// of 12 blocks, each two firing sequences of the 16 lasers at the block's azimuth and half a step
// later, strongest-return mode. The simulator's rays are a grid of columns (azimuth) × channels
// (elevation), so each returned point goes back to its laser and firing. The simulated scan is
// instantaneous; its packets are spread over one revolution (0.1 s at 600 rpm) around its stamp.
#include <array>
#include <cstdint>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/sim/lidar.hpp"

namespace hazmap::sim {

struct VelodynePacket {
  std::int64_t time_ns = 0;
  std::array<std::uint8_t, 1206> bytes{};
};

/// Throws hazmap::Error naming `where` unless `lidar` has the VLP-16's layout (16 channels from
/// -15° to 15°, a multiple of 24 columns per revolution).
void checkVlp16Layout(const LidarConfig& lidar, const std::string& where);
/// The packets of one revolution whose middle is `stamp` (s). Points are in the sensor frame as
/// simulateScan gives them (x forward, y left, z up).
std::vector<VelodynePacket> vlp16Packets(const LabeledCloud& scan, const LidarConfig& lidar, double stamp);

}  // namespace hazmap::sim
