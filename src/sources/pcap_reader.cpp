#include "hazmap/sources/pcap_reader.hpp"

#include <pcap/pcap.h>

#include <algorithm>
#include <array>
#include <fstream>

#include "hazmap/core/error.hpp"
#include "sources/pcap_datagrams.hpp"

namespace hazmap {

struct PcapReader::Impl {
  std::string name;
  PcapOptions options;
  pcap_t* handle = nullptr;
  std::FILE* file = nullptr;  // owned by `handle` once opened
  int link_type = 0;
  bool nanoseconds = false;
  std::int64_t file_size = -1;  // -1: unknown (a pipe)
  std::int64_t last_good_offset = 0;
  std::uint64_t frames = 0;
  bool finished = false;
  PcapLoss loss;
  pcap_detail::DatagramAssembler assembler;

  ~Impl() {
    if (handle) pcap_close(handle);
    else if (file) std::fclose(file);
  }

  void open(std::FILE* f) {
    file = f;
    if (std::fseek(f, 0, SEEK_END) == 0) {
      file_size = std::ftell(f);
      std::rewind(f);
    }
    std::array<char, PCAP_ERRBUF_SIZE> errbuf{};
    handle = pcap_fopen_offline_with_tstamp_precision(f, PCAP_TSTAMP_PRECISION_NANO, errbuf.data());
    if (!handle) fail(name, std::string("not a readable packet capture: ") + errbuf.data());
    nanoseconds = pcap_get_tstamp_precision(handle) == PCAP_TSTAMP_PRECISION_NANO;
    link_type = pcap_datalink(handle);
    if (!pcap_detail::supportedLinkType(link_type)) {
      const char* link_name = pcap_datalink_val_to_name(link_type);
      fail(name, "link type " + std::to_string(link_type) + " (" + (link_name ? link_name : "unknown") +
                     ") is not supported (Ethernet, Linux cooked SLL/SLL2, raw IP, loopback are)");
    }
    last_good_offset = std::ftell(f);
  }

  /// Records why reading stopped early: the bytes after the last complete record.
  void stopAtTruncation() {
    const std::int64_t unread = file_size >= 0 ? file_size - last_good_offset : 0;
    loss.bytes_unread = static_cast<std::uint64_t>(std::max<std::int64_t>(unread, 0));
    loss.notices.push_back(name + ": capture ends mid-record after " + std::to_string(frames) +
                           " records (offset " + std::to_string(last_good_offset) + ", " +
                           std::to_string(loss.bytes_unread) + " bytes unread): " +
                           pcap_geterr(handle));
  }

  void finish() {
    if (finished) return;
    finished = true;
    const std::uint64_t incomplete = assembler.expired() + assembler.pending();
    loss.incomplete_datagrams = incomplete;
    if (incomplete > 0)
      loss.notices.push_back(name + ": " + std::to_string(incomplete) +
                             " fragmented datagrams missing a fragment");
    if (loss.snapped_frames > 0)
      loss.notices.push_back(name + ": " + std::to_string(loss.snapped_frames) +
                             " records cut short by the capture's snap length");
    if (loss.malformed_frames > 0)
      loss.notices.push_back(name + ": " + std::to_string(loss.malformed_frames) +
                             " records with malformed IP/UDP headers skipped");
  }

  bool wanted(std::uint16_t port) const {
    const auto& ports = options.destination_ports;
    return ports.empty() || std::find(ports.begin(), ports.end(), port) != ports.end();
  }

  bool next(UdpPacket& packet) {
    while (!finished) {
      pcap_pkthdr* header = nullptr;
      const std::uint8_t* bytes = nullptr;
      const int status = pcap_next_ex(handle, &header, &bytes);
      if (status == PCAP_ERROR_BREAK) break;  // end of file
      if (status != 1) {
        stopAtTruncation();
        break;
      }
      const std::uint64_t index = frames++;
      last_good_offset = std::ftell(file);
      if (header->caplen < header->len) {
        ++loss.snapped_frames;
        continue;
      }
      pcap_detail::Datagram datagram;
      switch (assembler.push(link_type, {bytes, header->caplen}, index, datagram)) {
        case pcap_detail::FrameResult::Malformed: ++loss.malformed_frames; continue;
        case pcap_detail::FrameResult::NotUdp: ++loss.other_frames; continue;
        case pcap_detail::FrameResult::Fragment: continue;
        case pcap_detail::FrameResult::Datagram: break;
      }
      if (!wanted(datagram.destination_port)) continue;
      const std::int64_t sub = nanoseconds ? header->ts.tv_usec : std::int64_t{header->ts.tv_usec} * 1000;
      packet.time_ns = std::int64_t{header->ts.tv_sec} * 1'000'000'000 + sub;
      packet.time = static_cast<double>(header->ts.tv_sec) + static_cast<double>(sub) * 1e-9;
      packet.source_port = datagram.source_port;
      packet.destination_port = datagram.destination_port;
      packet.ipv6 = datagram.ipv6;
      packet.frame_index = index;
      packet.payload = datagram.payload;
      return true;
    }
    finish();
    return false;
  }
};

PcapReader::PcapReader(const std::filesystem::path& path, PcapOptions options)
    : impl_(std::make_unique<Impl>()) {
  impl_->name = path.string();
  impl_->options = std::move(options);
  if (std::filesystem::is_directory(path)) fail(impl_->name, "is a directory, not a packet capture");
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) fail(impl_->name, "cannot open the packet capture");
  impl_->open(f);
}

PcapReader::PcapReader(std::FILE* file, const std::string& name, PcapOptions options)
    : impl_(std::make_unique<Impl>()) {
  impl_->name = name;
  impl_->options = std::move(options);
  if (!file) fail(name, "cannot open the packet capture");
  impl_->open(file);
}

PcapReader::~PcapReader() = default;

bool PcapReader::next(UdpPacket& packet) { return impl_->next(packet); }
const PcapLoss& PcapReader::loss() const { return impl_->loss; }
int PcapReader::linkType() const { return impl_->link_type; }
std::uint64_t PcapReader::framesRead() const { return impl_->frames; }
const std::string& PcapReader::name() const { return impl_->name; }

bool isPcap(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::array<unsigned char, 4> m{};
  if (!in.read(reinterpret_cast<char*>(m.data()), 4)) return false;
  const std::uint32_t le = m[0] | m[1] << 8 | m[2] << 16 | std::uint32_t{m[3]} << 24;
  switch (le) {
    case 0xa1b2c3d4: case 0xd4c3b2a1:  // microseconds, either byte order
    case 0xa1b23c4d: case 0x4d3cb2a1:  // nanoseconds
    case 0x0a0d0d0a:                    // pcapng section header block
      return true;
    default:
      return false;
  }
}

}  // namespace hazmap
