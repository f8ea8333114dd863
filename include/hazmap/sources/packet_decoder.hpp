#pragma once
// Packet decoders of spinning LiDARs: raw UDP payloads (from a pcap capture or a bag's packet
// messages) in, full scans out, cut at the azimuth wrap like the manufacturers' drivers do.
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap {

/// A decoded scan: points in the sensor frame with intensity and absolute per-point times (s).
struct DecodedScan {
  double stamp = 0.0;  ///< time of the scan's first point (s)
  LabeledCloud cloud;
  std::vector<std::uint16_t> ring;         ///< laser/beam index per point
  std::vector<std::uint8_t> return_type;   ///< per point; decoder-specific meaning (documented there)
};

class PacketDecoder {
 public:
  virtual ~PacketDecoder() = default;
  /// Feeds one UDP payload received at `packet_time` (s). Payloads of other kinds (e.g.
  /// Velodyne position packets, Ouster IMU packets) are ignored. Throws hazmap::Error
  /// naming `where` on a packet of the right size but impossible content.
  virtual void addPacket(std::span<const std::uint8_t> payload, double packet_time,
                         const std::string& where) = 0;
  /// A completed scan, if one is ready (call after each addPacket until it returns nullopt).
  virtual std::optional<DecodedScan> takeScan() = 0;
  /// At the end of input: the partial scan being assembled, if any.
  virtual std::optional<DecodedScan> flush() = 0;
  virtual std::string describe() const = 0;  ///< e.g. "Velodyne VLP-16 (dual return)"
};

}  // namespace hazmap
