#include "hazmap/sources/udp_receiver.hpp"

#include <arpa/inet.h>
#include <linux/sock_diag.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {

constexpr std::size_t kMaxDatagram = 65536;
constexpr int kSocketBuffer = 16 << 20;  // asked for; the kernel caps it at net.core.rmem_max

int bindUdp(std::uint16_t port, std::uint16_t& bound) {
  const std::string where = "UDP port " + std::to_string(port);
  const int s = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (s < 0) fail(where, std::string("cannot open a socket: ") + std::strerror(errno));
  const int one = 1;
  ::setsockopt(s, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one);
  ::setsockopt(s, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one);
  ::setsockopt(s, SOL_SOCKET, SO_RCVBUF, &kSocketBuffer, sizeof kSocketBuffer);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_ANY);
  address.sin_port = htons(port);
  if (::bind(s, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    const int e = errno;
    ::close(s);
    fail(where, e == EADDRINUSE ? "already in use (another hazmap live, a driver, or a replay bound there?)"
                                : std::string("cannot be bound: ") + std::strerror(e));
  }
  socklen_t length = sizeof address;
  ::getsockname(s, reinterpret_cast<sockaddr*>(&address), &length);
  bound = ntohs(address.sin_port);
  return s;
}

}  // namespace

UdpReceiver::UdpReceiver(const std::vector<std::uint16_t>& ports, std::size_t queue_bytes)
    : queue_bytes_limit_(queue_bytes) {
  try {
    for (std::uint16_t p : ports) {
      std::uint16_t bound = 0;
      sockets_.push_back(bindUdp(p, bound));
      ports_.push_back(bound);
    }
  } catch (...) {
    for (int s : sockets_) ::close(s);
    throw;
  }
  last_overflow_.assign(sockets_.size(), 0);
  thread_ = std::thread([this] { receiveLoop(); });
}

UdpReceiver::~UdpReceiver() {
  stop();
  for (int s : sockets_) ::close(s);
}

void UdpReceiver::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void UdpReceiver::receiveLoop() {
  std::vector<pollfd> fds;
  for (int s : sockets_) fds.push_back({s, POLLIN, 0});
  std::vector<std::uint8_t> buffer(kMaxDatagram);
  while (!stop_) {
    // A short timeout: the destructor's stop is seen within it.
    if (::poll(fds.data(), fds.size(), 100) <= 0) continue;
    for (std::size_t i = 0; i < fds.size(); ++i)
      if (fds[i].revents & POLLIN) receiveOne(i, buffer);
  }
  for (std::size_t i = 0; i < sockets_.size(); ++i) {
    while (receiveOne(i, buffer)) {
    }
    countLastDrops(i);
  }
}

/// SO_RXQ_OVFL tells drops only with the next datagram; drops after the last one are in the
/// socket's memory info.
void UdpReceiver::countLastDrops(std::size_t i) {
  std::uint32_t info[SK_MEMINFO_VARS] = {};
  socklen_t length = sizeof info;
  if (::getsockopt(sockets_[i], SOL_SOCKET, SO_MEMINFO, info, &length) != 0 || length <= SK_MEMINFO_DROPS * 4) return;
  std::lock_guard lock(mutex_);
  const std::uint32_t dropped = info[SK_MEMINFO_DROPS] - last_overflow_[i];
  stats_.kernel_dropped += dropped;
  lost_since_queued_ += dropped;
  last_overflow_[i] = info[SK_MEMINFO_DROPS];
}

std::uint64_t UdpReceiver::lostAfterLast() const {
  std::lock_guard lock(mutex_);
  return lost_since_queued_;
}

bool UdpReceiver::receiveOne(std::size_t i, std::vector<std::uint8_t>& buffer) {
  iovec io{buffer.data(), buffer.size()};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t))];
  msghdr message{};
  message.msg_iov = &io;
  message.msg_iovlen = 1;
  message.msg_control = control;
  message.msg_controllen = sizeof control;
  const ssize_t n = ::recvmsg(sockets_[i], &message, MSG_DONTWAIT);
  if (n < 0) return false;
  ReceivedDatagram d;
  d.port = ports_[i];
  std::optional<std::uint32_t> overflow;
  for (cmsghdr* c = CMSG_FIRSTHDR(&message); c; c = CMSG_NXTHDR(&message, c)) {
    if (c->cmsg_level != SOL_SOCKET) continue;
    if (c->cmsg_type == SO_TIMESTAMPNS) {
      timespec t;
      std::memcpy(&t, CMSG_DATA(c), sizeof t);
      d.time_ns = std::int64_t{t.tv_sec} * 1'000'000'000 + t.tv_nsec;
    } else if (c->cmsg_type == SO_RXQ_OVFL) {
      overflow.emplace();
      std::memcpy(&*overflow, CMSG_DATA(c), sizeof *overflow);
    }
  }
  if (d.time_ns == 0) {
    timespec t;
    ::clock_gettime(CLOCK_REALTIME, &t);
    d.time_ns = std::int64_t{t.tv_sec} * 1'000'000'000 + t.tv_nsec;
  }
  std::lock_guard lock(mutex_);
  if (overflow) {
    // The kernel's counter runs since the socket was opened; the difference is new drops.
    const std::uint32_t dropped = *overflow - last_overflow_[i];
    stats_.kernel_dropped += dropped;
    lost_since_queued_ += dropped;
    last_overflow_[i] = *overflow;
  }
  ++stats_.received;
  stats_.last_received_ns = d.time_ns;
  if (message.msg_flags & MSG_TRUNC) {
    ++stats_.truncated;
    ++lost_since_queued_;
    return true;
  }
  if (queue_bytes_ + static_cast<std::size_t>(n) > queue_bytes_limit_) {
    ++stats_.queue_dropped;
    ++lost_since_queued_;
    return true;
  }
  d.payload.assign(buffer.begin(), buffer.begin() + n);
  d.lost_before = std::exchange(lost_since_queued_, 0);
  queue_bytes_ += d.payload.size();
  queue_.push_back(std::move(d));
  ready_.notify_one();
  return true;
}

std::optional<ReceivedDatagram> UdpReceiver::pop(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  if (!ready_.wait_for(lock, timeout, [&] { return !queue_.empty(); })) return std::nullopt;
  ReceivedDatagram d = std::move(queue_.front());
  queue_.pop_front();
  queue_bytes_ -= d.payload.size();
  return d;
}

UdpReceiverStats UdpReceiver::stats() const {
  std::lock_guard lock(mutex_);
  UdpReceiverStats s = stats_;
  s.queued = queue_.size();
  s.queued_bytes = queue_bytes_;
  return s;
}

}  // namespace hazmap
