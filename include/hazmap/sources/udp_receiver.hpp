#pragma once
// UDP datagrams from a sensor on the network, received on a thread of their own into a bounded
// queue, so a slow consumer (tracking, an autosave) costs counted drops rather than memory or a
// stalled socket. Plain POSIX sockets: the kernel's overflow counter (SO_RXQ_OVFL) and receive
// time stamps (SO_TIMESTAMPNS) come as recvmsg control messages, which Boost.Asio does not expose.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace hazmap {

struct ReceivedDatagram {
  std::int64_t time_ns = 0;  ///< kernel receive time (ns since the epoch)
  std::uint16_t port = 0;    ///< the local port it arrived on
  std::uint64_t lost_before = 0;  ///< datagrams dropped (kernel, queue) since the previous one
  std::vector<std::uint8_t> payload;
};

struct UdpReceiverStats {
  std::uint64_t received = 0;       ///< datagrams taken from the sockets
  std::uint64_t kernel_dropped = 0; ///< dropped by the kernel: socket buffer full (SO_RXQ_OVFL)
  std::uint64_t queue_dropped = 0;  ///< dropped because the queue was full (consumer too slow)
  std::uint64_t truncated = 0;      ///< larger than the receive buffer: dropped
  std::size_t queued = 0;           ///< datagrams waiting for the decoder now
  std::size_t queued_bytes = 0;     ///< their payload bytes
  std::int64_t last_received_ns = 0;  ///< receive time of the newest datagram (0: none yet)
};

class UdpReceiver {
 public:
  /// Binds every port of `ports` (0: a free port, see port()) on all IPv4 addresses and starts
  /// receiving. `queue_bytes` bounds the queued payloads. Throws hazmap::Error naming the port
  /// when it cannot be bound (in use, no permission).
  UdpReceiver(const std::vector<std::uint16_t>& ports, std::size_t queue_bytes);
  ~UdpReceiver();  ///< stops and joins the thread
  UdpReceiver(const UdpReceiver&) = delete;
  UdpReceiver& operator=(const UdpReceiver&) = delete;

  /// Stops receiving after reading what the sockets already hold (what was sent before the stop
  /// is not lost); the queue can still be popped.
  void stop();
  /// The next datagram, waiting at most `timeout`; nullopt when none came.
  std::optional<ReceivedDatagram> pop(std::chrono::milliseconds timeout);
  UdpReceiverStats stats() const;  ///< thread-safe
  /// Datagrams dropped after the last one queued (after stop(): the stream's lost tail).
  std::uint64_t lostAfterLast() const;
  std::uint16_t port(std::size_t i) const { return ports_.at(i); }  ///< as bound

 private:
  void receiveLoop();
  /// False when the socket had nothing to read.
  bool receiveOne(std::size_t socket_index, std::vector<std::uint8_t>& buffer);
  void countLastDrops(std::size_t socket_index);

  std::vector<int> sockets_;
  std::vector<std::uint16_t> ports_;
  std::size_t queue_bytes_limit_;
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<ReceivedDatagram> queue_;
  std::size_t queue_bytes_ = 0;
  UdpReceiverStats stats_;
  std::uint64_t lost_since_queued_ = 0;
  std::vector<std::uint32_t> last_overflow_;  // per socket: the kernel's running drop count
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace hazmap
