#pragma once
// Builds packet captures byte by byte for the tests: UDP segments, IPv4 (fragmented to an MTU)
// and IPv6 (with fragment headers) packets, Ethernet (optionally VLAN-tagged) and Linux cooked
// frames, classic pcap files in micro- or nanosecond precision.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

namespace hazmap::test::pcap {

using Bytes = std::vector<std::uint8_t>;

inline void put16(Bytes& b, std::size_t at, std::uint16_t v) { b[at] = v >> 8; b[at + 1] = v & 0xff; }

inline Bytes udpSegment(const Bytes& payload, std::uint16_t sport, std::uint16_t dport) {
  Bytes s(8);
  put16(s, 0, sport);
  put16(s, 2, dport);
  put16(s, 4, static_cast<std::uint16_t>(8 + payload.size()));
  s.insert(s.end(), payload.begin(), payload.end());
  return s;
}

/// IPv4 packets of `segment`, fragmented to `mtu` bytes of IP packet (0: one packet).
inline std::vector<Bytes> ipv4Packets(const Bytes& segment, std::uint16_t id, std::size_t mtu) {
  const std::size_t chunk = mtu ? (mtu - 20) / 8 * 8 : segment.size();
  std::vector<Bytes> out;
  for (std::size_t off = 0; off < segment.size(); off += chunk) {
    const std::size_t n = std::min(chunk, segment.size() - off);
    Bytes ip(20);
    ip[0] = 0x45;
    put16(ip, 2, static_cast<std::uint16_t>(20 + n));
    put16(ip, 4, id);
    const bool more = off + n < segment.size();
    put16(ip, 6, static_cast<std::uint16_t>((more ? 0x2000 : 0) | off / 8));
    ip[8] = 64;
    ip[9] = 17;
    const std::uint8_t addrs[8] = {192, 168, 1, 100, 192, 168, 1, 1};
    std::memcpy(&ip[12], addrs, 8);
    ip.insert(ip.end(), segment.begin() + off, segment.begin() + off + n);
    out.push_back(ip);
  }
  return out;
}

/// IPv6 packets of `segment`, with a fragment header when `mtu` > 0.
inline std::vector<Bytes> ipv6Packets(const Bytes& segment, std::uint32_t id, std::size_t mtu) {
  std::vector<Bytes> out;
  const std::size_t chunk = mtu ? (mtu - 48) / 8 * 8 : segment.size();
  for (std::size_t off = 0; off < segment.size(); off += chunk) {
    const std::size_t n = std::min(chunk, segment.size() - off);
    Bytes ip(40);
    ip[0] = 0x60;
    ip[7] = 64;
    for (int i = 0; i < 16; ++i) ip[8 + i] = 0xfe, ip[24 + i] = static_cast<std::uint8_t>(i);
    if (mtu) {
      ip[6] = 44;
      Bytes frag(8);
      frag[0] = 17;
      const bool more = off + n < segment.size();
      put16(frag, 2, static_cast<std::uint16_t>(off | (more ? 1 : 0)));
      frag[4] = id >> 24, frag[5] = id >> 16, frag[6] = id >> 8, frag[7] = id & 0xff;
      ip.insert(ip.end(), frag.begin(), frag.end());
    } else {
      ip[6] = 17;
    }
    ip.insert(ip.end(), segment.begin() + off, segment.begin() + off + n);
    put16(ip, 4, static_cast<std::uint16_t>(ip.size() - 40));
    out.push_back(ip);
  }
  return out;
}

inline Bytes ethernet(const Bytes& ip, bool v6, bool vlan) {
  Bytes f(12, 0x11);
  if (vlan) f.insert(f.end(), {0x81, 0x00, 0x00, 0x05});
  f.push_back(v6 ? 0x86 : 0x08);
  f.push_back(v6 ? 0xdd : 0x00);
  f.insert(f.end(), ip.begin(), ip.end());
  while (f.size() < 60) f.push_back(0);  // Ethernet minimum frame: padding after the IP packet
  return f;
}

inline Bytes linuxCooked(const Bytes& ip, bool v6) {
  Bytes f(16, 0);
  f[1] = 0x00;  // packet sent to us
  f[14] = v6 ? 0x86 : 0x08;
  f[15] = v6 ? 0xdd : 0x00;
  f.insert(f.end(), ip.begin(), ip.end());
  return f;
}

struct Record {
  std::uint32_t sec = 0, sub = 0;
  Bytes frame;
  std::uint32_t original_length = 0;  // 0: the frame's size
};

/// A classic little-endian pcap file.
inline Bytes pcapFile(std::uint32_t link_type, bool nano, const std::vector<Record>& records) {
  Bytes f;
  auto u32 = [&](std::uint32_t v) { for (int i = 0; i < 4; ++i) f.push_back((v >> (8 * i)) & 0xff); };
  auto u16 = [&](std::uint16_t v) { f.push_back(v & 0xff); f.push_back(v >> 8); };
  u32(nano ? 0xa1b23c4d : 0xa1b2c3d4);
  u16(2), u16(4), u32(0), u32(0), u32(262144), u32(link_type);
  for (const Record& r : records) {
    u32(r.sec), u32(r.sub), u32(static_cast<std::uint32_t>(r.frame.size()));
    u32(r.original_length ? r.original_length : static_cast<std::uint32_t>(r.frame.size()));
    f.insert(f.end(), r.frame.begin(), r.frame.end());
  }
  return f;
}

inline std::filesystem::path writeFile(const std::filesystem::path& path, const Bytes& bytes) {
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                              static_cast<std::streamsize>(bytes.size()));
  return path;
}

}  // namespace hazmap::test::pcap
