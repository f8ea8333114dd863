// libFuzzer target: packet-capture reader (libpcap through fmemopen; link layers, IPv4/IPv6,
// fragment reassembly, truncated files).
#include <cstdio>
#include <cstdlib>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/pcap_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  std::FILE* f = fmemopen(const_cast<std::uint8_t*>(data), size, "rb");
  if (!f) return 0;
  try {
    hazmap::PcapReader reader(f, "fuzz.pcap");
    hazmap::UdpPacket p;
    std::uint64_t packets = 0;
    while (reader.next(p)) {
      // A datagram is at most 64 KiB and lies inside the input or the reassembly buffer.
      if (p.payload.size() > 65535 + 8) std::abort();
      volatile std::uint8_t sink = 0;
      for (std::uint8_t b : p.payload) sink = sink ^ b;
      if (p.frame_index >= reader.framesRead()) std::abort();
      ++packets;
    }
    const auto& loss = reader.loss();
    if (loss.bytes_unread > size) std::abort();
    if (packets + loss.snapped_frames + loss.malformed_frames + loss.other_frames > reader.framesRead()) std::abort();
    if (reader.next(p)) std::abort();  // stays at the end
  } catch (const hazmap::Error&) {
  }
  return 0;
}
