#pragma once
// Packet captures (.pcap, and .pcapng through libpcap) as a stream of UDP datagrams: the raw
// payloads a LiDAR sent, with their capture time and ports. Ethernet (with VLAN tags), Linux
// cooked (SLL, SLL2), raw IP and BSD loopback frames; IPv4 and IPv6; fragmented datagrams are
// reassembled (Ouster's legacy packets exceed the 1500-byte MTU). A truncated capture (a
// recorder killed mid-write) reads up to its last complete record and says what was lost.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace hazmap {

/// One UDP datagram. `payload` stays valid until the next call to PcapReader::next().
struct UdpPacket {
  std::int64_t time_ns = 0;          ///< capture time of the frame that completed it (ns since epoch)
  double time = 0.0;                 ///< the same in seconds
  std::uint16_t source_port = 0;
  std::uint16_t destination_port = 0;
  bool ipv6 = false;
  std::uint64_t frame_index = 0;     ///< 0-based index of the capture record that completed it
  std::span<const std::uint8_t> payload;
};

/// What the reader could not read or skipped.
struct PcapLoss {
  std::uint64_t bytes_unread = 0;          ///< bytes after the last complete capture record
  std::uint64_t snapped_frames = 0;        ///< records cut short by the capture's snap length
  std::uint64_t incomplete_datagrams = 0;  ///< fragmented datagrams missing a fragment
  std::uint64_t malformed_frames = 0;      ///< bad IP/UDP headers or lengths
  std::uint64_t other_frames = 0;          ///< not UDP (ARP, TCP, ICMP, ...): skipped, not an error
  std::vector<std::string> notices;        ///< one line each, naming the file
  /// True when something the capture should have held could not be read (other_frames aside).
  bool anyLost() const {
    return bytes_unread || snapped_frames || incomplete_datagrams || malformed_frames;
  }
};

struct PcapOptions {
  /// Keep only datagrams sent to one of these UDP ports (empty: all).
  std::vector<std::uint16_t> destination_ports;
};

class PcapReader {
 public:
  /// Opens a capture file. Throws hazmap::Error naming the path if it cannot be opened or is not
  /// a capture, or if its link type is not one listed above.
  explicit PcapReader(const std::filesystem::path& path, PcapOptions options = {});
  /// Reads an already open stream (e.g. fmemopen'd bytes); takes ownership of `file` (closed by
  /// the reader, also on failure). `name` is used in messages.
  PcapReader(std::FILE* file, const std::string& name, PcapOptions options = {});
  ~PcapReader();
  PcapReader(const PcapReader&) = delete;
  PcapReader& operator=(const PcapReader&) = delete;

  /// The next UDP datagram that passes the port filter; false at the end of the capture (or at
  /// its truncated tail, recorded in loss()).
  bool next(UdpPacket& packet);
  const PcapLoss& loss() const;
  int linkType() const;          ///< libpcap's DLT_* value
  std::uint64_t framesRead() const;  ///< capture records read so far
  const std::string& name() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// True if the file starts with a pcap or pcapng magic number.
bool isPcap(const std::filesystem::path& path);

}  // namespace hazmap
