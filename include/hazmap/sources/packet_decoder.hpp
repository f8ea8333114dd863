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
#include "hazmap/io/imu.hpp"

namespace hazmap {

/// A decoded scan: points in the sensor frame with intensity and absolute per-point times (s).
struct DecodedScan {
  double stamp = 0.0;  ///< time of the scan's first point (s)
  LabeledCloud cloud;
  std::vector<std::uint16_t> ring;         ///< laser/beam index per point
  std::vector<std::uint8_t> return_type;   ///< per point; decoder-specific meaning (documented there)
};

/// What a decoder tolerated instead of refusing the recording: odd datagrams, packets and blocks
/// it wrapped or skipped, counted per kind (e.g. "Velodyne block azimuths of 36000 wrapped to
/// 0"). The first of each kind is warned once (spdlog) naming where it was; the rest are only
/// counted. A recording is refused only when nothing of it decodes (`decoded_packets` == 0).
struct DecoderQuirks {
  std::vector<std::pair<std::string, std::uint64_t>> counts;  ///< kind → count, first seen first
  std::uint64_t decoded_packets = 0;  ///< packets that gave data

  void note(const std::string& kind, const std::string& where, std::uint64_t n = 1);
  std::uint64_t count(const std::string& kind) const;
  std::uint64_t total() const;
  /// "3 Velodyne block azimuths of 36000 wrapped to 0, 1 datagram of 1000 bytes skipped"; empty if none.
  std::string summary() const;
};

class PacketDecoder {
 public:
  virtual ~PacketDecoder() = default;
  /// Feeds one UDP payload received at `packet_time` (s). Payloads of other kinds (e.g.
  /// Velodyne position packets, Ouster IMU packets) are ignored; odd ones (truncated, of
  /// another model, blocks out of order or with impossible azimuths) are wrapped or skipped
  /// and counted in quirks(). `where` names the datagram for the one warning per kind.
  virtual void addPacket(std::span<const std::uint8_t> payload, double packet_time,
                         const std::string& where) = 0;
  /// A completed scan, if one is ready (call after each addPacket until it returns nullopt).
  virtual std::optional<DecodedScan> takeScan() = 0;
  /// At the end of input: the partial scan being assembled, if any.
  virtual std::optional<DecodedScan> flush() = 0;
  /// The IMU samples decoded since the last call (sensors that send IMU packets beside their
  /// lidar packets: Ouster), on the clock of the scans' per-point times, sensor frame.
  virtual std::vector<ImuSample> takeImu() { return {}; }
  virtual std::string describe() const = 0;  ///< e.g. "Velodyne VLP-16 (dual return)"
  /// What was tolerated so far (see DecoderQuirks).
  const DecoderQuirks& quirks() const { return quirks_; }

 protected:
  DecoderQuirks quirks_;
};

}  // namespace hazmap
