#include "sources/live_feeds.hpp"

#include <chrono>
#include <cstring>
#include <optional>

#include "hazmap/sources/live_source.hpp"
#include "hazmap/sources/pcap_reader.hpp"

namespace hazmap::sources {

namespace {

class NetworkFeed final : public DatagramFeed {
 public:
  NetworkFeed(const std::vector<std::uint16_t>& ports, std::size_t queue_bytes, const std::atomic<bool>* stop)
      : receiver_(ports, queue_bytes), stop_(stop) {}

  FeedItem::Got next(FeedItem& item) override {
    if (!stopped_ && stop_ && stop_->load()) {
      receiver_.stop();
      stopped_ = true;
    }
    // Short waits: a stop request is seen within one.
    current_ = receiver_.pop(std::chrono::milliseconds(stopped_ ? 0 : 100));
    if (!current_) {
      if (!stopped_) return FeedItem::Idle;
      item.lost_before = receiver_.lostAfterLast();
      return FeedItem::End;
    }
    item.time_ns = current_->time_ns;
    item.port = current_->port;
    item.lost_before = current_->lost_before;
    item.payload = current_->payload;
    return FeedItem::Datagram;
  }
  std::string where() const override { return "UDP port " + std::to_string(receiver_.port(0)); }
  UdpReceiverStats receiverStats() const override { return receiver_.stats(); }
  std::uint16_t port(std::size_t i) const override { return receiver_.port(i); }

 private:
  UdpReceiver receiver_;
  const std::atomic<bool>* stop_;
  bool stopped_ = false;
  std::optional<ReceivedDatagram> current_;
};

class SpoolFeed final : public DatagramFeed {
 public:
  explicit SpoolFeed(const std::filesystem::path& spool) : reader_(spool) {}

  FeedItem::Got next(FeedItem& item) override {
    std::uint64_t lost = 0;
    UdpPacket packet;
    while (reader_.next(packet)) {
      if (packet.destination_port == kSpoolLossPort && packet.payload.size() == sizeof lost) {
        std::uint64_t n = 0;
        std::memcpy(&n, packet.payload.data(), sizeof n);
        lost += n;
        continue;
      }
      item.time_ns = packet.time_ns;
      item.port = packet.destination_port;
      item.lost_before = lost;
      item.payload = packet.payload;
      return FeedItem::Datagram;
    }
    item.lost_before = lost;
    return FeedItem::End;
  }
  std::string where() const override { return reader_.name(); }

 private:
  PcapReader reader_;
};

}  // namespace

std::unique_ptr<DatagramFeed> makeNetworkFeed(const std::vector<std::uint16_t>& ports, std::size_t queue_bytes,
                                              const std::atomic<bool>* stop) {
  return std::make_unique<NetworkFeed>(ports, queue_bytes, stop);
}

std::unique_ptr<DatagramFeed> makeSpoolFeed(const std::filesystem::path& spool) {
  return std::make_unique<SpoolFeed>(spool);
}

}  // namespace hazmap::sources
