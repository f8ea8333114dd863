#include "sources/scan_assembler.hpp"

#include <algorithm>
#include <cmath>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/ros_messages.hpp"

namespace hazmap::sources {

double sweepMiddle(const LabeledCloud& cloud, double fallback) {
  if (cloud.timestamps.empty()) return fallback;
  double first = std::numeric_limits<double>::infinity(), last = -first;
  for (double t : cloud.timestamps)
    if (std::isfinite(t)) first = std::min(first, t), last = std::max(last, t);
  return std::isfinite(first) ? 0.5 * (first + last) : fallback;
}

ScanAssembler::ScanAssembler(LidarKind kind, std::unique_ptr<PacketDecoder> decoder)
    : kind_(kind), decoder_(std::move(decoder)) {
  if (kind_ != LidarKind::PointCloud2 && !decoder_) fail("scan assembler", "packet topic without a decoder");
}

void ScanAssembler::addMessage(const BagMessage& message, const std::string& where, std::deque<RawScan>& out) {
  const Serialization s = message.topic->serialization;
  const double log_time = static_cast<double>(message.log_time_ns) * 1e-9;
  switch (kind_) {
    case LidarKind::PointCloud2: {
      const PointCloud2 msg = decodePointCloud2(message.data, s, where);
      RawScan scan;
      scan.cloud = pointCloud2ToCloud(msg, where);
      scan.stamp = sweepMiddle(scan.cloud, msg.header.stamp);
      if (!scan.cloud.empty()) out.push_back(std::move(scan));
      return;
    }
    case LidarKind::VelodyneScan: {
      const VelodyneScanMsg msg = decodeVelodyneScan(message.data, s, where);
      for (const LidarPacket& p : msg.packets)
        addPacket(p.data, p.stamp, where, out);
      return;
    }
    case LidarKind::HesaiScan: {
      const VelodyneScanMsg msg = decodePandarScan(message.data, s, where);
      for (const LidarPacket& p : msg.packets) addPacket(p.data, p.stamp, where, out);
      return;
    }
    case LidarKind::OusterPackets: {
      const LidarPacket p = decodeOusterPacket(message.data, s, where);
      // ouster_ros/PacketMsg has no stamp: the recorder's receive time stands in.
      addPacket(p.data, p.stamp > 0 ? p.stamp : log_time, where, out);
      return;
    }
  }
}

void ScanAssembler::addPacket(std::span<const std::uint8_t> payload, double time, const std::string& where,
                              std::deque<RawScan>& out) {
  decoder_->addPacket(payload, time, where);
  take(out);
}

void ScanAssembler::take(std::deque<RawScan>& out) {
  while (std::optional<DecodedScan> d = decoder_->takeScan())
    if (!d->cloud.empty()) {
      last_points_ = d->cloud.size();
      out.push_back({sweepMiddle(d->cloud, d->stamp), std::move(d->cloud)});
    }
}

std::vector<std::string> ScanAssembler::flush(const std::string& where, std::deque<RawScan>& out) {
  if (!decoder_) return {};
  take(out);
  std::optional<DecodedScan> d = decoder_->flush();
  for (std::optional<DecodedScan> more; (more = decoder_->flush());) {  // a decoder may hold more than one
    if (d && !d->cloud.empty()) {
      last_points_ = d->cloud.size();
      out.push_back({sweepMiddle(d->cloud, d->stamp), std::move(d->cloud)});
    }
    d = std::move(more);
  }
  const DecoderQuirks& q = decoder_->quirks();
  // One odd packet never costs the recording; a recording of nothing but odd packets is refused.
  if (q.decoded_packets == 0 && q.total() > 0)
    fail(where, "no decodable LiDAR packet: " + q.summary());
  std::vector<std::string> notices;
  if (q.total() > 0) notices.push_back(where + ": tolerated " + q.summary());
  if (!d || d->cloud.empty()) return notices;
  // The rotation the recording ended in: a scan only if it is not a small piece of one (a
  // capture shorter than a rotation still gives its one partial scan).
  if (last_points_ > 0 && 2 * d->cloud.size() < last_points_)
    notices.push_back("the last " + std::to_string(d->cloud.size()) +
                      " points (a partial rotation at the end) dropped");
  else
    out.push_back({sweepMiddle(d->cloud, d->stamp), std::move(d->cloud)});
  return notices;
}

std::string ScanAssembler::describe() const {
  if (!decoder_) return "PointCloud2";
  const DecoderQuirks& q = decoder_->quirks();
  return q.total() > 0 ? decoder_->describe() + "; tolerated " + q.summary() : decoder_->describe();
}

}  // namespace hazmap::sources
