#pragma once
// Where a live stream's datagrams come from (live_source.cpp): the network (a UdpReceiver until
// the stop flag is set) or a live run's spool capture (its loss marks read back).
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "hazmap/sources/udp_receiver.hpp"

namespace hazmap::sources {

struct FeedItem {
  enum Got { Datagram, Idle, End };
  std::int64_t time_ns = 0;
  std::uint16_t port = 0;
  std::uint64_t lost_before = 0;
  std::span<const std::uint8_t> payload;  ///< valid until the feed's next call
};

class DatagramFeed {
 public:
  virtual ~DatagramFeed() = default;
  /// Datagram: `item` holds one. Idle: none for a while (the network is quiet). End: no more;
  /// item.lost_before then counts datagrams lost after the last one.
  virtual FeedItem::Got next(FeedItem& item) = 0;
  virtual std::string where() const = 0;
  virtual UdpReceiverStats receiverStats() const { return {}; }
  virtual std::uint16_t port(std::size_t) const { return 0; }
};

/// Binds `ports` (data first). After `*stop` turns true, what the sockets and queue hold is
/// still delivered, then End.
std::unique_ptr<DatagramFeed> makeNetworkFeed(const std::vector<std::uint16_t>& ports, std::size_t queue_bytes,
                                              const std::atomic<bool>* stop);
std::unique_ptr<DatagramFeed> makeSpoolFeed(const std::filesystem::path& spool);

}  // namespace hazmap::sources
