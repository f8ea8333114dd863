// hazmap live's scan stream: datagrams (from the network, or from the spool of an earlier live
// stream) → the sensor's packet decoder → scans cut at the wrap, as a capture's are
// (pcap_scan_source.cpp). See live_source.hpp for the spool and the skipped scans.
#include "hazmap/sources/live_source.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <fstream>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/hesai.hpp"
#include "hazmap/sources/pcap_reader.hpp"
#include "hazmap/sources/pcap_writer.hpp"
#include "sources/assembled_scans.hpp"
#include "sources/live_feeds.hpp"
#include "sources/packet_decoders.hpp"
#include "sources/scan_assembler.hpp"

namespace hazmap {

namespace {

using namespace sources;
using SteadyClock = std::chrono::steady_clock;

std::unique_ptr<ScanAssembler> makeAssembler(LiveSensor sensor, const ScanSourceOptions& options) {
  switch (sensor) {
    case LiveSensor::Velodyne:
      return std::make_unique<ScanAssembler>(LidarKind::VelodyneScan, makeVelodyneDecoderFor(options));
    case LiveSensor::Hesai:
      return std::make_unique<ScanAssembler>(LidarKind::HesaiScan, makeHesaiDecoderFor(options));
    case LiveSensor::Ouster: break;
  }
  const std::filesystem::path& metadata = options.sensor_metadata;
  if (metadata.empty())
    fail("--sensor-metadata", "an Ouster sensor needs its metadata JSON (ouster-cli source <host> metadata "
                              "> meta.json)");
  std::ifstream in(metadata, std::ios::binary);
  if (!in) fail(metadata.string(), "cannot open the sensor metadata");
  const std::string text(std::istreambuf_iterator<char>(in), {});
  return std::make_unique<ScanAssembler>(LidarKind::OusterPackets, makeOusterDecoderFor(text, metadata.string()));
}

/// The capture's conversion of a time stamp (PcapReader), so the spool's scans are the same bits.
double seconds(std::int64_t time_ns) {
  return static_cast<double>(time_ns / 1'000'000'000) + static_cast<double>(time_ns % 1'000'000'000) * 1e-9;
}

class LiveStream final : public LiveScanSource {
 public:
  LiveStream(LiveSensor sensor, std::unique_ptr<DatagramFeed> feed, const ScanSourceOptions& options,
             const std::filesystem::path& spool, double silence_seconds)
      : options_(options), feed_(std::move(feed)), assembler_(makeAssembler(sensor, options)),
        silence_seconds_(silence_seconds), last_heard_(SteadyClock::now()) {
    table_ = options.class_table ? *options.class_table : ClassTable::defaults();
    if (!spool.empty()) spool_.emplace(spool);
  }

  std::optional<Scan> next() override {
    while (!ended_ && !scans_.ready()) {
      FeedItem item;
      switch (feed_->next(item)) {
        case FeedItem::Idle: watchSilence(); break;
        case FeedItem::End: end(item); break;
        case FeedItem::Datagram: take(item); break;
      }
    }
    if (scans_.empty()) return std::nullopt;
    return scans_.pop();  // as a capture's scans (pcap_scan_source.cpp)
  }
  std::optional<std::size_t> size() const override { return std::nullopt; }
  const ClassTable& classTable() const override { return table_; }
  std::string describe() const override { return feed_->where() + " (" + assembler_->describe() + ")"; }

  LiveStats stats() const override {
    LiveStats s = stats_;
    s.receiver = feed_->receiverStats();
    s.decoder = assembler_->describe();
    return s;
  }
  UdpReceiverStats receiverStats() const override { return feed_->receiverStats(); }
  void flushSpool() override {
    if (spool_) spool_->flush();
  }
  std::uint16_t dataPort() const override { return feed_->port(0); }
  std::uint16_t auxiliaryPort() const override { return feed_->port(1); }

 private:
  /// One datagram: into the spool (after a mark of what was lost before it), then the decoder.
  void take(const FeedItem& item) {
    heard();
    markLoss(item.lost_before, item.time_ns);
    last_time_ns_ = item.time_ns;
    if (spool_) spool_->write(item.time_ns, item.port, item.payload);
    const std::size_t before = scans_.pending().size();
    assembler_->addPacket(item.payload, seconds(item.time_ns),
                          feed_->where() + ": datagram " + std::to_string(datagrams_++), scans_.pending());
    // A scan cut by the first datagram after a loss ends where the loss began, so the loss may
    // have taken the cut too: the scan starting here then lacks its head and is skipped as well.
    if (item.lost_before > 0 && scans_.pending().size() > before) skip_ = 2;
    skipDamaged(before);
    scans_.imu().append(assembler_->takeImu());
  }

  void markLoss(std::uint64_t lost, std::int64_t time_ns) {
    if (lost == 0) return;
    stats_.lost += lost;
    skip_ = std::max<std::size_t>(skip_, 1);
    if (!spool_) return;
    std::uint8_t mark[8];
    std::memcpy(mark, &lost, sizeof mark);
    spool_->write(time_ns, kSpoolLossPort, mark);
  }

  /// The scans a loss fell into are skipped, not passed on with a hole.
  void skipDamaged(std::size_t before) {
    auto& pending = scans_.pending();
    while (skip_ > 0 && pending.size() > before) {
      pending.erase(pending.begin() + static_cast<std::ptrdiff_t>(before));
      ++stats_.scans_skipped;
      --skip_;
    }
  }

  /// The scan being assembled, unless datagrams were lost after the last one.
  void end(const FeedItem& item) {
    ended_ = true;
    markLoss(item.lost_before, last_time_ns_);
    const std::size_t before = scans_.pending().size();
    for (const auto& line : assembler_->flush(feed_->where(), scans_.pending())) notice(line);
    skipDamaged(before);
    scans_.imu().append(assembler_->takeImu());
    if (const std::string line = scans_.imu().notice(feed_->where()); !line.empty()) notice(line);
    if (spool_) spool_->flush();
  }

  void heard() {
    last_heard_ = SteadyClock::now();
    if (!waiting_) return;
    waiting_ = false;
    notice("sensor back on UDP port " + std::to_string(dataPort()));
  }

  /// Silence longer than silence_seconds: said once; the stream goes on waiting.
  void watchSilence() {
    if (waiting_ || std::chrono::duration<double>(SteadyClock::now() - last_heard_).count() <= silence_seconds_)
      return;
    waiting_ = true;
    ++stats_.silences;
    notice("waiting for sensor on UDP port " + std::to_string(dataPort()));
  }

  void notice(const std::string& line) const {
    if (options_.notice) options_.notice(line);
  }

  ScanSourceOptions options_;
  std::unique_ptr<DatagramFeed> feed_;
  std::unique_ptr<ScanAssembler> assembler_;
  std::optional<PcapWriter> spool_;
  AssembledScans scans_;
  ClassTable table_;
  LiveStats stats_;
  double silence_seconds_;
  SteadyClock::time_point last_heard_;
  bool waiting_ = false, ended_ = false;
  std::size_t skip_ = 0;  // scans still to skip after a loss
  std::uint64_t datagrams_ = 0;
  std::int64_t last_time_ns_ = 0;
};

}  // namespace

std::unique_ptr<LiveScanSource> openLiveSource(const LiveSourceOptions& live, const ScanSourceOptions& options) {
  const std::uint16_t data = live.port.value_or(standardDataPort(live.sensor));
  const std::uint16_t auxiliary =
      !live.port ? standardAuxiliaryPort(live.sensor) : data == 0 ? std::uint16_t{0} : std::uint16_t(data + 1);
  if (live.sensor == LiveSensor::Ouster) makeAssembler(live.sensor, options);  // metadata first: before binding
  auto feed = makeNetworkFeed({data, auxiliary}, live.queue_bytes, live.stop);
  return std::make_unique<LiveStream>(live.sensor, std::move(feed), options, live.spool, live.silence_seconds);
}

std::unique_ptr<ScanSource> openLiveSpool(const std::filesystem::path& spool, LiveSensor sensor,
                                          const ScanSourceOptions& options) {
  return std::make_unique<LiveStream>(sensor, makeSpoolFeed(spool), options, std::filesystem::path(), 1e300);
}

}  // namespace hazmap
