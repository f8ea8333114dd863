#pragma once
// A small ROS 1 bag (format 2.0) writer following http://wiki.ros.org/Bags/Format/2.0, and
// ROS 1 serializers of a few messages: builds the bags the ROS 1 reader is tested and fuzzed
// on (no bz2/lz4 ROS 1 bag exists in the shared data). Tests and fuzz seeds only.
#include <cstdint>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "sources/bag_readers.hpp"
#include "sources/compression.hpp"

namespace hazmap::test {

/// ROS 1 serialization: little-endian, unaligned, strings and arrays with a u32 count.
struct Ros1Out {
  std::vector<std::uint8_t> b;
  template <class T>
  void put(T v) {
    const std::size_t at = b.size();
    b.resize(at + sizeof v);
    std::memcpy(b.data() + at, &v, sizeof v);
  }
  void str(const std::string& s) {
    put<std::uint32_t>(static_cast<std::uint32_t>(s.size()));
    b.insert(b.end(), s.begin(), s.end());
  }
  void bytes(const std::vector<std::uint8_t>& d, bool with_count = true) {
    if (with_count) put<std::uint32_t>(static_cast<std::uint32_t>(d.size()));
    b.insert(b.end(), d.begin(), d.end());
  }
  void header(std::uint32_t sec, const std::string& frame) {
    put<std::uint32_t>(7);  // seq
    put<std::uint32_t>(sec);
    put<std::uint32_t>(500000000);
    str(frame);
  }
};

inline std::vector<std::uint8_t> ros1Cloud(std::uint32_t sec, float x0) {
  Ros1Out o;
  o.header(sec, "velodyne");
  o.put<std::uint32_t>(1), o.put<std::uint32_t>(2);  // height, width
  o.put<std::uint32_t>(3);
  for (const auto& [name, off] : {std::pair{"x", 0u}, {"y", 4u}, {"z", 8u}}) {
    o.str(name), o.put<std::uint32_t>(off), o.put<std::uint8_t>(7), o.put<std::uint32_t>(1);
  }
  o.put<std::uint8_t>(0), o.put<std::uint32_t>(12), o.put<std::uint32_t>(24);
  std::vector<std::uint8_t> data(24);
  const float xyz[6] = {x0, 2, 3, x0 + 1, 5, 6};
  std::memcpy(data.data(), xyz, 24);
  o.bytes(data);
  o.put<std::uint8_t>(1);
  return o.b;
}

inline std::vector<std::uint8_t> ros1Odometry(std::uint32_t sec, double x) {
  Ros1Out o;
  o.header(sec, "odom");
  o.str("base_link");
  for (const double v : {x, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0}) o.put(v);
  for (int i = 0; i < 36 + 6 + 36; ++i) o.put(0.0);
  return o.b;
}

inline std::vector<std::uint8_t> ros1VelodyneScan(std::uint32_t sec, int packets) {
  Ros1Out o;
  o.header(sec, "velodyne");
  o.put<std::uint32_t>(static_cast<std::uint32_t>(packets));
  for (int p = 0; p < packets; ++p) {
    o.put<std::uint32_t>(sec), o.put<std::uint32_t>(1000u * p);
    o.bytes(std::vector<std::uint8_t>(1206, static_cast<std::uint8_t>(p)), false);
  }
  return o.b;
}

/// One record: header fields, data.
inline std::vector<std::uint8_t> record(const std::vector<std::pair<std::string, std::vector<std::uint8_t>>>& fields,
                                 const std::vector<std::uint8_t>& data) {
  Ros1Out h;
  for (const auto& [name, value] : fields) {
    h.put<std::uint32_t>(static_cast<std::uint32_t>(name.size() + 1 + value.size()));
    h.b.insert(h.b.end(), name.begin(), name.end());
    h.b.push_back('=');
    h.b.insert(h.b.end(), value.begin(), value.end());
  }
  Ros1Out r;
  r.bytes(h.b);
  r.bytes(data);
  return r.b;
}
template <class T>
inline std::vector<std::uint8_t> le(T v) {
  std::vector<std::uint8_t> b(sizeof v);
  std::memcpy(b.data(), &v, sizeof v);
  return b;
}
inline std::vector<std::uint8_t> text(const std::string& s) { return {s.begin(), s.end()}; }

struct Msg {
  std::uint32_t conn;
  std::uint32_t sec;
  std::vector<std::uint8_t> data;
};
struct Conn {
  std::string topic, type;
};

inline std::vector<std::uint8_t> connectionRecord(std::uint32_t id, const Conn& c) {
  const auto info = record({{"topic", text(c.topic)}, {"type", text(c.type)}, {"md5sum", text("0123456789abcdef0123456789abcdef")},
                            {"message_definition", text("# test\n")}}, {});
  // The connection's data is its header fields alone (no trailing data length).
  std::uint32_t hlen;
  std::memcpy(&hlen, info.data(), 4);
  return record({{"op", {0x07}}, {"conn", le(id)}, {"topic", text(c.topic)}},
                std::vector<std::uint8_t>(info.begin() + 4, info.begin() + 4 + hlen));
}

/// A bag of `chunks` chunks in `compression`, with or without its index section.
inline std::vector<std::uint8_t> buildBag(const std::vector<Conn>& conns, const std::vector<std::vector<Msg>>& chunks,
                                   const std::string& compression, bool indexed) {
  std::vector<std::uint8_t> bag(sources::kRos1Magic, sources::kRos1Magic + 13);
  const std::size_t header_at = bag.size();
  std::vector<std::uint8_t> chunk_infos;
  for (const auto& msgs : chunks) {
    std::vector<std::uint8_t> inner;
    std::set<std::uint32_t> declared;
    std::map<std::uint32_t, std::uint32_t> per_conn;
    std::uint32_t t0 = UINT32_MAX, t1 = 0;
    for (const auto& m : msgs) {
      if (declared.insert(m.conn).second) {
        const auto c = connectionRecord(m.conn, conns[m.conn]);
        inner.insert(inner.end(), c.begin(), c.end());
      }
      const auto r = record({{"op", {0x02}}, {"conn", le(m.conn)}, {"time", le(std::uint64_t{m.sec})}}, m.data);
      inner.insert(inner.end(), r.begin(), r.end());
      ++per_conn[m.conn], t0 = std::min(t0, m.sec), t1 = std::max(t1, m.sec);
    }
    std::vector<std::uint8_t> stored = inner;
    if (compression == "bz2") stored = sources::compressBz2(inner);
    if (compression == "lz4") stored = sources::compressLz4Frame(inner);
    const std::uint64_t chunk_pos = bag.size() + 4096 * (bag.size() == header_at);
    const auto chunk = record({{"op", {0x05}}, {"compression", text(compression)}, {"size", le(static_cast<std::uint32_t>(inner.size()))}}, stored);
    std::vector<std::uint8_t> counts;
    for (const auto& [c, n] : per_conn) {
      const auto a = le(c), b = le(n);
      counts.insert(counts.end(), a.begin(), a.end());
      counts.insert(counts.end(), b.begin(), b.end());
    }
    const auto info = record({{"op", {0x06}}, {"ver", le(1u)}, {"chunk_pos", le(chunk_pos)}, {"start_time", le(std::uint64_t{t0})},
                              {"end_time", le(std::uint64_t{t1})}, {"count", le(static_cast<std::uint32_t>(per_conn.size()))}}, counts);
    chunk_infos.insert(chunk_infos.end(), info.begin(), info.end());
    if (bag.size() == header_at) bag.resize(header_at + 4096, ' ');  // room for the bag header
    bag.insert(bag.end(), chunk.begin(), chunk.end());
  }
  if (bag.size() == header_at) bag.resize(header_at + 4096, ' ');
  const std::uint64_t index_pos = indexed ? bag.size() : 0;
  if (indexed) {
    for (std::uint32_t i = 0; i < conns.size(); ++i) {
      const auto c = connectionRecord(i, conns[i]);
      bag.insert(bag.end(), c.begin(), c.end());
    }
    bag.insert(bag.end(), chunk_infos.begin(), chunk_infos.end());
  }
  auto header = record({{"op", {0x03}}, {"index_pos", le(index_pos)}, {"conn_count", le(static_cast<std::uint32_t>(conns.size()))},
                        {"chunk_count", le(static_cast<std::uint32_t>(chunks.size()))}}, {});
  const std::size_t pad = 4096 - header.size();
  header = record({{"op", {0x03}}, {"index_pos", le(index_pos)}, {"conn_count", le(static_cast<std::uint32_t>(conns.size()))},
                   {"chunk_count", le(static_cast<std::uint32_t>(chunks.size()))}}, std::vector<std::uint8_t>(pad, ' '));
  std::copy(header.begin(), header.end(), bag.begin() + static_cast<std::ptrdiff_t>(header_at));
  return bag;
}


}  // namespace hazmap::test
