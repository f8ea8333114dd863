#include "sources/pcap_datagrams.hpp"

#include <pcap/dlt.h>

#include <algorithm>
#include <cstring>

namespace hazmap::pcap_detail {
namespace {

constexpr std::uint8_t kUdp = 17;
constexpr std::size_t kMaxPending = 64;        // reassemblies in flight at once
constexpr std::uint64_t kFragmentLifetime = 1024;  // frames a reassembly may wait for a fragment
constexpr std::uint32_t kMaxDatagram = 65535 + 8;  // IPv4's limit (IPv6 jumbograms are not fragmented)

std::uint16_t be16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] << 8 | p[1]); }
std::uint32_t be32(const std::uint8_t* p) {
  return std::uint32_t{p[0]} << 24 | std::uint32_t{p[1]} << 16 | std::uint32_t{p[2]} << 8 | p[3];
}

enum class Link { Ip, NotIp, Malformed };

/// Strips the link-layer header; `ip` is the IPv4/IPv6 packet that follows.
Link stripLink(int link_type, std::span<const std::uint8_t> frame, std::span<const std::uint8_t>& ip) {
  std::size_t header = 0;
  std::uint16_t ethertype = 0;  // 0: decide by the IP version nibble
  switch (link_type) {
    case DLT_EN10MB:
      header = 14;
      if (frame.size() < header) return Link::Malformed;
      ethertype = be16(&frame[12]);
      while (ethertype == 0x8100 || ethertype == 0x88a8 || ethertype == 0x9100) {  // VLAN tags
        if (frame.size() < header + 4) return Link::Malformed;
        ethertype = be16(&frame[header + 2]);
        header += 4;
      }
      break;
    case DLT_LINUX_SLL:
      header = 16;
      if (frame.size() < header) return Link::Malformed;
      ethertype = be16(&frame[14]);
      break;
    case DLT_LINUX_SLL2:
      header = 20;
      if (frame.size() < header) return Link::Malformed;
      ethertype = be16(&frame[0]);
      break;
    case DLT_NULL:
    case DLT_LOOP:
      header = 4;  // address family, in an endianness that differs by platform: use the IP version
      break;
    default:  // DLT_RAW, DLT_IPV4, DLT_IPV6: the frame is the IP packet
      break;
  }
  if (frame.size() < header) return Link::Malformed;
  if (ethertype != 0 && ethertype != 0x0800 && ethertype != 0x86dd) return Link::NotIp;
  ip = frame.subspan(header);
  if (ip.empty()) return Link::Malformed;
  const int version = ip[0] >> 4;
  if (ethertype == 0x0800 && version != 4) return Link::Malformed;
  if (ethertype == 0x86dd && version != 6) return Link::Malformed;
  if (version != 4 && version != 6) return ethertype == 0 ? Link::NotIp : Link::Malformed;
  return Link::Ip;
}

}  // namespace

bool supportedLinkType(int link_type) {
  switch (link_type) {
    case DLT_EN10MB: case DLT_LINUX_SLL: case DLT_LINUX_SLL2: case DLT_NULL: case DLT_LOOP:
    case DLT_RAW: case DLT_IPV4: case DLT_IPV6:
      return true;
    default:
      return false;
  }
}

FrameResult DatagramAssembler::push(int link_type, std::span<const std::uint8_t> frame,
                                    std::uint64_t frame_index, Datagram& out) {
  std::span<const std::uint8_t> packet;
  switch (stripLink(link_type, frame, packet)) {
    case Link::NotIp: return FrameResult::NotUdp;
    case Link::Malformed: return FrameResult::Malformed;
    case Link::Ip: break;
  }
  Ip ip;
  const FrameResult parsed = (packet[0] >> 4) == 4 ? parseIpv4(packet, ip) : parseIpv6(packet, ip);
  if (parsed != FrameResult::Datagram) return parsed;
  if (ip.key.protocol != kUdp) return FrameResult::NotUdp;
  if (ip.fragmented) return reassemble(ip, frame_index, out);
  return parseUdp(ip.payload, ip.key.ipv6, out);
}

FrameResult DatagramAssembler::parseIpv4(std::span<const std::uint8_t> p, Ip& ip) const {
  if (p.size() < 20) return FrameResult::Malformed;
  const std::size_t header = std::size_t{p[0] & 0x0fu} * 4;
  std::size_t total = be16(&p[2]);
  // Ethernet pads short frames, so the capture may hold more than the IP length.
  if (header < 20 || total < header || header > p.size()) return FrameResult::Malformed;
  const std::uint16_t flags_offset = be16(&p[6]);
  const bool fragment = (flags_offset & 0x3fff) != 0;
  // Some senders get the length wrong: a VLP-16's position packets claim 1,234 bytes in a
  // 554-byte frame. The record was captured whole (snapped ones never get here), so a whole
  // datagram is read by its UDP length; a fragment must be exact, it cannot be checked later.
  if (total > p.size()) {
    if (fragment) return FrameResult::Malformed;
    total = p.size();
  }
  ip.key.ipv6 = false;
  ip.key.protocol = p[9];
  ip.key.id = be16(&p[4]);
  std::memcpy(ip.key.source.data(), &p[12], 4);
  std::memcpy(ip.key.destination.data(), &p[16], 4);
  ip.more_fragments = (flags_offset & 0x2000) != 0;
  ip.fragment_offset = std::uint32_t{flags_offset & 0x1fffu} * 8;
  ip.fragmented = fragment;
  ip.payload = p.subspan(header, total - header);
  return FrameResult::Datagram;
}

FrameResult DatagramAssembler::parseIpv6(std::span<const std::uint8_t> p, Ip& ip) const {
  if (p.size() < 40) return FrameResult::Malformed;
  const std::size_t length = be16(&p[4]);
  if (length == 0 || 40 + length > p.size()) return FrameResult::Malformed;  // 0: jumbogram
  ip.key.ipv6 = true;
  std::memcpy(ip.key.source.data(), &p[8], 16);
  std::memcpy(ip.key.destination.data(), &p[24], 16);
  std::uint8_t next = p[6];
  std::span<const std::uint8_t> rest = p.subspan(40, length);
  for (int guard = 0; guard < 16; ++guard) {
    if (next == 0 || next == 43 || next == 60 || next == 51) {  // hop-by-hop, routing, dest, AH
      if (rest.size() < 8) return FrameResult::Malformed;
      const std::size_t len = next == 51 ? (std::size_t{rest[1]} + 2) * 4 : (std::size_t{rest[1]} + 1) * 8;
      if (len > rest.size()) return FrameResult::Malformed;
      next = rest[0];
      rest = rest.subspan(len);
    } else if (next == 44) {  // fragment header
      if (rest.size() < 8) return FrameResult::Malformed;
      const std::uint16_t offset_flags = be16(&rest[2]);
      ip.fragmented = true;
      ip.more_fragments = (offset_flags & 1u) != 0;
      ip.fragment_offset = std::uint32_t{offset_flags & 0xfff8u};
      ip.key.id = be32(&rest[4]);
      next = rest[0];
      rest = rest.subspan(8);
    } else {
      ip.key.protocol = next;
      ip.payload = rest;
      return FrameResult::Datagram;
    }
  }
  return FrameResult::Malformed;
}

FrameResult DatagramAssembler::reassemble(const Ip& ip, std::uint64_t frame_index, Datagram& out) {
  const std::uint32_t begin = ip.fragment_offset;
  const std::uint32_t end = begin + static_cast<std::uint32_t>(ip.payload.size());
  if (end > kMaxDatagram || (ip.more_fragments && ip.payload.size() % 8 != 0))
    return FrameResult::Malformed;
  expireOlderThan(frame_index);
  auto it = std::find_if(pending_.begin(), pending_.end(),
                         [&](const Pending& p) { return p.key == ip.key; });
  if (it == pending_.end()) {
    if (pending_.size() >= kMaxPending) {  // evict the stalest
      pending_.erase(std::min_element(pending_.begin(), pending_.end(),
          [](const Pending& a, const Pending& b) { return a.last_frame < b.last_frame; }));
      ++expired_;
    }
    pending_.push_back(Pending{ip.key, frame_index, -1, {}, {}});
    it = pending_.end() - 1;
  }
  Pending& p = *it;
  if (!ip.more_fragments) {
    if (p.total >= 0 && p.total != end) return FrameResult::Malformed;
    p.total = end;
  }
  if (p.total >= 0 && std::max<std::size_t>(end, p.bytes.size()) > static_cast<std::size_t>(p.total))
    return FrameResult::Malformed;
  p.last_frame = frame_index;
  if (p.bytes.size() < end) p.bytes.resize(end);
  std::copy(ip.payload.begin(), ip.payload.end(), p.bytes.begin() + begin);
  p.received.emplace_back(begin, end);
  if (p.total < 0) return FrameResult::Fragment;
  std::sort(p.received.begin(), p.received.end());
  std::uint32_t covered = 0;
  for (const auto& [b, e] : p.received) {
    if (b > covered) return FrameResult::Fragment;  // a hole
    covered = std::max(covered, e);
  }
  if (covered < p.total) return FrameResult::Fragment;
  assembled_.swap(p.bytes);
  assembled_.resize(static_cast<std::size_t>(p.total));
  const bool ipv6 = p.key.ipv6;
  pending_.erase(it);
  return parseUdp(assembled_, ipv6, out);
}

FrameResult DatagramAssembler::parseUdp(std::span<const std::uint8_t> s, bool ipv6, Datagram& out) const {
  if (s.size() < 8) return FrameResult::Malformed;
  const std::size_t length = be16(&s[4]);
  if (length < 8 || length > s.size()) return FrameResult::Malformed;
  out.source_port = be16(&s[0]);
  out.destination_port = be16(&s[2]);
  out.ipv6 = ipv6;
  out.payload = s.subspan(8, length - 8);
  return FrameResult::Datagram;
}

void DatagramAssembler::expireOlderThan(std::uint64_t frame_index) {
  const auto stale = [&](const Pending& p) { return p.last_frame + kFragmentLifetime < frame_index; };
  const auto n = std::count_if(pending_.begin(), pending_.end(), stale);
  if (n == 0) return;
  expired_ += static_cast<std::uint64_t>(n);
  pending_.erase(std::remove_if(pending_.begin(), pending_.end(), stale), pending_.end());
}

}  // namespace hazmap::pcap_detail
