#pragma once
// LiDAR messages of a bag (PointCloud2, VelodyneScan, Ouster packets) or datagrams of a capture
// in, scans out: one scan per PointCloud2, packets through a packet decoder cut at the wrap.
#include <deque>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/packet_decoder.hpp"
#include "hazmap/sources/scan_source.hpp"
#include "sources/topic_selection.hpp"

namespace hazmap::sources {

/// A scan before the recording's poses are attached.
struct RawScan {
  double stamp = 0.0;
  LabeledCloud cloud;
};

class ScanAssembler {
 public:
  /// `decoder`: the packet decoder for VelodyneScan / Ouster packet topics (nullptr for PointCloud2).
  ScanAssembler(LidarKind kind, std::unique_ptr<PacketDecoder> decoder);
  /// One LiDAR message (bag). Completed scans are appended to `out`.
  void addMessage(const BagMessage& message, const std::string& where, std::deque<RawScan>& out);
  /// One raw UDP payload (capture or packet message).
  void addPacket(std::span<const std::uint8_t> payload, double time, const std::string& where,
                 std::deque<RawScan>& out);
  /// At the end of the recording: the scan being assembled, unless it is a small piece of a
  /// rotation. Returns notices: that piece dropped, what the decoder tolerated (DecoderQuirks).
  /// Throws hazmap::Error naming `where` when no packet decoded and some were odd.
  std::vector<std::string> flush(const std::string& where, std::deque<RawScan>& out);
  /// The IMU samples its packet decoder decoded since the last call (Ouster IMU packets).
  std::vector<ImuSample> takeImu() { return decoder_ ? decoder_->takeImu() : std::vector<ImuSample>{}; }
  /// The decoder's description, with what it tolerated when anything.
  std::string describe() const;

 private:
  void take(std::deque<RawScan>& out);
  LidarKind kind_;
  std::unique_ptr<PacketDecoder> decoder_;
  std::size_t last_points_ = 0;  ///< of the last complete scan
};

/// A decoded cloud's reference time (Scan::stamp): the middle of its sweep when it has per-point
/// times, else `fallback` (the message's stamp).
double sweepMiddle(const LabeledCloud& cloud, double fallback);

}  // namespace hazmap::sources
