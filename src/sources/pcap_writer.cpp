#include "hazmap/sources/pcap_writer.hpp"

#include <pcap/pcap.h>

#include <cerrno>
#include <cstring>
#include <vector>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {

constexpr std::size_t kMaxPayload = 65535 - 20 - 8;

void put16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v >> 8);
  p[1] = static_cast<std::uint8_t>(v & 0xff);
}

/// IPv4 + UDP headers in front of `payload`, from 192.168.1.201 (a Velodyne's factory address)
/// to 192.168.1.77; checksums zero (allowed for UDP over IPv4; readers do not check the IP one).
void frame(std::vector<std::uint8_t>& out, std::uint16_t source_port, std::uint16_t destination_port,
           std::span<const std::uint8_t> payload) {
  out.assign(28 + payload.size(), 0);
  std::uint8_t* ip = out.data();
  ip[0] = 0x45;
  put16(ip + 2, static_cast<std::uint16_t>(out.size()));
  ip[6] = 0x40;  // don't fragment
  ip[8] = 64;
  ip[9] = 17;
  const std::uint8_t addresses[8] = {192, 168, 1, 201, 192, 168, 1, 77};
  std::memcpy(ip + 12, addresses, 8);
  std::uint8_t* udp = ip + 20;
  put16(udp, source_port);
  put16(udp + 2, destination_port);
  put16(udp + 4, static_cast<std::uint16_t>(8 + payload.size()));
  if (!payload.empty()) std::memcpy(udp + 8, payload.data(), payload.size());
}

}  // namespace

struct PcapWriter::Handles {
  pcap_t* pcap = nullptr;
  pcap_dumper_t* dumper = nullptr;
  std::vector<std::uint8_t> frame;
  ~Handles() {
    if (dumper) pcap_dump_close(dumper);
    if (pcap) pcap_close(pcap);
  }
};

PcapWriter::PcapWriter(const std::filesystem::path& path) : path_(path), handles_(std::make_unique<Handles>()) {
  handles_->pcap = pcap_open_dead_with_tstamp_precision(DLT_RAW, 65535, PCAP_TSTAMP_PRECISION_NANO);
  if (!handles_->pcap) fail(path.string(), "cannot start a capture");
  handles_->dumper = pcap_dump_open(handles_->pcap, path.c_str());
  if (!handles_->dumper) fail(path.string(), std::string("cannot write: ") + pcap_geterr(handles_->pcap));
}

PcapWriter::~PcapWriter() = default;

void PcapWriter::write(std::int64_t time_ns, std::uint16_t destination_port, std::span<const std::uint8_t> payload,
                       std::uint16_t source_port) {
  if (payload.size() > kMaxPayload)
    fail(path_.string(), "a datagram of " + std::to_string(payload.size()) + " bytes exceeds UDP's 65507");
  frame(handles_->frame, source_port, destination_port, payload);
  pcap_pkthdr header{};
  // With nanosecond precision libpcap takes tv_usec as nanoseconds.
  header.ts.tv_sec = static_cast<time_t>(time_ns / 1'000'000'000);
  header.ts.tv_usec = static_cast<suseconds_t>(time_ns % 1'000'000'000);
  header.caplen = header.len = static_cast<bpf_u_int32>(handles_->frame.size());
  pcap_dump(reinterpret_cast<u_char*>(handles_->dumper), &header, handles_->frame.data());
  ++datagrams_;
}

void PcapWriter::flush() {
  if (pcap_dump_flush(handles_->dumper) != 0) fail(path_.string(), std::string("cannot write: ") + std::strerror(errno));
}

}  // namespace hazmap
