#pragma once
// UDP datagrams into a packet capture (.pcap, nanosecond time stamps, raw IPv4 frames) that
// PcapReader, Wireshark and tcpdump read: what `hazmap live` received (its spool, re-read for the
// map) and what `hazmap simulate --format pcap` makes of the simulated VLP-16.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>

namespace hazmap {

class PcapWriter {
 public:
  /// Creates (truncates) `path`. Throws hazmap::Error naming it when it cannot be written.
  explicit PcapWriter(const std::filesystem::path& path);
  ~PcapWriter();
  PcapWriter(const PcapWriter&) = delete;
  PcapWriter& operator=(const PcapWriter&) = delete;

  /// One datagram sent to `destination_port` at `time_ns` (ns since the epoch). Payloads over
  /// 65,507 bytes (UDP's limit) are refused with hazmap::Error.
  void write(std::int64_t time_ns, std::uint16_t destination_port, std::span<const std::uint8_t> payload,
             std::uint16_t source_port = 0);
  /// Pushes what was written to the file, so a reader opened now sees every datagram so far.
  void flush();
  std::uint64_t datagrams() const { return datagrams_; }
  const std::filesystem::path& path() const { return path_; }

 private:
  struct Handles;
  std::filesystem::path path_;
  std::unique_ptr<Handles> handles_;
  std::uint64_t datagrams_ = 0;
};

}  // namespace hazmap
