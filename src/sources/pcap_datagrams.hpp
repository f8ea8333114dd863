#pragma once
// Captured link-layer frames → UDP datagrams: the link header, IPv4/IPv6 (with extension
// headers), fragment reassembly and the UDP header. Internal to pcap_reader.cpp; separate so the
// byte parsing can be read (and tested) without libpcap.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace hazmap::pcap_detail {

struct Datagram {
  std::uint16_t source_port = 0, destination_port = 0;
  bool ipv6 = false;
  std::span<const std::uint8_t> payload;  ///< into the frame or the assembler's buffer
};

enum class FrameResult {
  Datagram,   ///< a complete UDP datagram is in `out`
  Fragment,   ///< a fragment was stored; its datagram is not complete yet
  NotUdp,     ///< a valid frame of another protocol (ARP, TCP, ...)
  Malformed,  ///< bad or inconsistent headers
};

/// Returns true if libpcap's DLT_* `link_type` is one the assembler understands.
bool supportedLinkType(int link_type);

class DatagramAssembler {
 public:
  /// Parses one captured frame. `frame_index` orders frames so stale fragments can expire.
  FrameResult push(int link_type, std::span<const std::uint8_t> frame, std::uint64_t frame_index,
                   Datagram& out);
  /// Datagrams dropped because a fragment never came (evicted so far).
  std::uint64_t expired() const { return expired_; }
  /// Datagrams still waiting for fragments (incomplete if the input has ended).
  std::size_t pending() const { return pending_.size(); }

 private:
  struct Key {
    std::array<std::uint8_t, 16> source{}, destination{};
    std::uint32_t id = 0;
    std::uint8_t protocol = 0;
    bool ipv6 = false;
    bool operator==(const Key&) const = default;
  };
  struct Pending {
    Key key;
    std::uint64_t last_frame = 0;
    std::int64_t total = -1;  ///< payload length once the last fragment is seen
    std::vector<std::uint8_t> bytes;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> received;  ///< [begin, end) ranges
  };
  struct Ip {
    Key key;
    bool fragmented = false, more_fragments = false;
    std::uint32_t fragment_offset = 0;
    std::span<const std::uint8_t> payload;  ///< after the IP (and extension) headers
  };

  FrameResult parseIpv4(std::span<const std::uint8_t> packet, Ip& ip) const;
  FrameResult parseIpv6(std::span<const std::uint8_t> packet, Ip& ip) const;
  FrameResult reassemble(const Ip& ip, std::uint64_t frame_index, Datagram& out);
  FrameResult parseUdp(std::span<const std::uint8_t> segment, bool ipv6, Datagram& out) const;
  void expireOlderThan(std::uint64_t frame_index);

  std::vector<Pending> pending_;
  std::vector<std::uint8_t> assembled_;
  std::uint64_t expired_ = 0;
};

}  // namespace hazmap::pcap_detail
