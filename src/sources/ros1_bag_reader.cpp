// ROS 1 bag format 2.0 (http://wiki.ros.org/Bags/Format/2.0): "#ROSBAG V2.0\n", then records
// of <u32 header length><header fields "name=value"><u32 data length><data>. The bag header
// points to the index section (connection and chunk-info records); without it (a recorder
// killed before closing) the chunks are scanned. Chunks are none, bz2 or lz4 (roslz4 = LZ4
// frames). Topic types are respelled the ROS 2 way ("sensor_msgs/msg/PointCloud2").
#include <cstring>
#include <map>
#include <set>
#include <string_view>

#include "bag_readers.hpp"
#include "block_merge.hpp"
#include "chunked_bag_reader.hpp"
#include "byte_cursor.hpp"
#include "compression.hpp"
#include "hazmap/core/error.hpp"
#include "mapped_file.hpp"

namespace hazmap::sources {
namespace {

using Bytes = std::span<const std::uint8_t>;

enum Op : std::uint8_t { kMessageData = 0x02, kBagHeader = 0x03, kIndexData = 0x04, kChunk = 0x05, kChunkInfo = 0x06, kConnection = 0x07 };
constexpr std::size_t kMagicSize = sizeof(kRos1Magic) - 1;

struct Record {
  std::uint64_t offset = 0;
  Bytes header, data;
};

/// Reads the record at the cursor; false (cursor unchanged) when it is cut short.
bool readRecord(ByteCursor& c, Record& r) {
  const std::size_t start = c.position();
  r.offset = c.fileOffset();
  if (c.remaining() < 4) return false;
  const auto header_len = c.read<std::uint32_t>();
  if (c.remaining() < std::uint64_t{header_len} + 4) return c.seek(start), false;
  r.header = c.bytes(header_len);
  const auto data_len = c.read<std::uint32_t>();
  if (c.remaining() < data_len) return c.seek(start), false;
  r.data = c.bytes(data_len);
  return true;
}

/// The header's fields, each "name=value" with a u32 length.
std::map<std::string_view, Bytes> headerFields(Bytes header, const std::string& where, std::uint64_t offset) {
  std::map<std::string_view, Bytes> fields;
  ByteCursor c(header, where, offset + 4);
  while (!c.atEnd()) {
    const auto field = c.bytes(c.read<std::uint32_t>(), "header field");
    const auto* eq = static_cast<const std::uint8_t*>(std::memchr(field.data(), '=', field.size()));
    if (!eq) c.failAt("header field without '='");
    const auto name_len = static_cast<std::size_t>(eq - field.data());
    fields[std::string_view(reinterpret_cast<const char*>(field.data()), name_len)] = field.subspan(name_len + 1);
  }
  return fields;
}

template <class T>
T field(const std::map<std::string_view, Bytes>& fields, std::string_view name, const std::string& where, std::uint64_t offset) {
  const auto it = fields.find(name);
  if (it == fields.end() || it->second.size() != sizeof(T))
    fail(where, "record at offset " + std::to_string(offset) + " lacks a " + std::to_string(sizeof(T)) +
                    "-byte '" + std::string(name) + "' field");
  T v;
  std::memcpy(&v, it->second.data(), sizeof(T));
  return v;
}

std::string textField(const std::map<std::string_view, Bytes>& fields, std::string_view name) {
  const auto it = fields.find(name);
  return it == fields.end() ? std::string() : std::string(reinterpret_cast<const char*>(it->second.data()), it->second.size());
}

/// ROS 1 time: u32 seconds, u32 nanoseconds.
std::int64_t rosTime(std::uint64_t packed) {
  return static_cast<std::int64_t>(packed & 0xFFFFFFFFu) * 1000000000 + static_cast<std::int64_t>(packed >> 32);
}

class Ros1BagReader final : public ChunkedBagReader {
 public:
  explicit Ros1BagReader(const std::filesystem::path& path) : ChunkedBagReader(path.string()), file_(path) {
    const Bytes bytes = file_.bytes();
    if (bytes.size() < kMagicSize || std::memcmp(bytes.data(), kRos1Magic, kMagicSize) != 0)
      fail(where_, "not a ROS 1 bag (no \"#ROSBAG V2.0\" at offset 0)");
    const std::uint64_t index_pos = readBagHeader();
    if (index_pos == 0 || !readIndex(index_pos)) linearScan();
    selected_.assign(topics_.size(), 1);
  }


 private:
  std::uint64_t readBagHeader();
  bool readIndex(std::uint64_t index_pos);
  void linearScan();
  void onConnection(const Record& r, const std::string& where);
  Bytes decodeChunk(const Record& r, std::vector<std::uint8_t>& buffer);
  void scanChunk(const Record& r);
  void loadBlock(const MergeBlock& b, std::vector<std::uint8_t>& buffer, std::vector<MergeEntry>& out) override;

  MappedFile file_;
  std::map<std::uint32_t, std::size_t> connection_topic_;  // conn id → topic index
  std::map<std::uint32_t, std::uint64_t> counts_;          // conn id → messages
};

std::uint64_t Ros1BagReader::readBagHeader() {
  ByteCursor c(file_.bytes(), where_);
  c.seek(kMagicSize);
  Record r;
  if (!readRecord(c, r)) {
    loss_.bytes_unread = c.remaining();
    loss_.notices.push_back(where_ + ": truncated inside the bag header record (offset " + std::to_string(kMagicSize) + ")");
    return 0;
  }
  const auto fields = headerFields(r.header, where_, r.offset);
  if (field<std::uint8_t>(fields, "op", where_, r.offset) != kBagHeader)
    fail(where_, "the first record (offset " + std::to_string(r.offset) + ") is not a bag header");
  const auto index_pos = field<std::uint64_t>(fields, "index_pos", where_, r.offset);
  if (index_pos != 0 && (index_pos < c.position() || index_pos >= file_.size())) {
    loss_.notices.push_back(where_ + ": bag header's index_pos " + std::to_string(index_pos) +
                            " is outside the file; scanning the chunks");
    return 0;
  }
  return index_pos;
}

void Ros1BagReader::onConnection(const Record& r, const std::string& where) {
  const auto fields = headerFields(r.header, where, r.offset);
  const auto id = field<std::uint32_t>(fields, "conn", where, r.offset);
  if (connection_topic_.count(id)) return;
  const auto info = headerFields(r.data, where, r.offset + 8 + r.header.size());
  TopicInfo t;
  t.name = textField(fields, "topic");
  t.type = ros2TypeName(textField(info, "type"));
  t.serialization = Serialization::Ros1;
  t.definition = textField(info, "message_definition");
  // Connections of one topic (several publishers) share one TopicInfo.
  for (std::size_t i = 0; i < topics_.size(); ++i)
    if (topics_[i].name == t.name && topics_[i].type == t.type) return void(connection_topic_[id] = i);
  connection_topic_[id] = topics_.size();
  topics_.push_back(std::move(t));
}

bool Ros1BagReader::readIndex(std::uint64_t index_pos) {
  ByteCursor c(file_.bytes(), where_);
  c.seek(index_pos);
  try {
    Record r;
    while (!c.atEnd()) {
      if (!readRecord(c, r)) c.failAt("index record cut short");
      const auto fields = headerFields(r.header, where_, r.offset);
      const auto op = field<std::uint8_t>(fields, "op", where_, r.offset);
      if (op == kConnection) onConnection(r, where_);
      if (op != kChunkInfo) continue;
      const auto chunk_pos = field<std::uint64_t>(fields, "chunk_pos", where_, r.offset);
      if (chunk_pos >= index_pos) fail(where_, "chunk info at offset " + std::to_string(r.offset) + " points past the index");
      extendRange(rosTime(field<std::uint64_t>(fields, "start_time", where_, r.offset)));
      extendRange(rosTime(field<std::uint64_t>(fields, "end_time", where_, r.offset)));
      blocks_.push_back({rosTime(field<std::uint64_t>(fields, "start_time", where_, r.offset)), chunk_pos, 0});
      ByteCursor counts(r.data, where_, r.offset);
      while (counts.remaining() >= 8) {
        const auto conn = counts.read<std::uint32_t>();
        const auto n = counts.read<std::uint32_t>();
        counts_[conn] += n;
      }
    }
  } catch (const Error& e) {
    loss_.notices.push_back(std::string(e.what()) + "; scanning the chunks instead of the index");
    topics_.clear(), connection_topic_.clear(), blocks_.clear(), counts_.clear(), any_time_ = false;
    return false;
  }
  for (const auto& [conn, n] : counts_)
    if (const auto it = connection_topic_.find(conn); it != connection_topic_.end()) topics_[it->second].message_count += n;
  return true;
}

void Ros1BagReader::linearScan() {
  ByteCursor c(file_.bytes(), where_);
  c.seek(kMagicSize);
  Record r;
  if (readRecord(c, r) == false) return;  // bag header cut short: already reported
  while (!c.atEnd()) {
    if (!readRecord(c, r)) {
      loss_.bytes_unread = c.remaining();
      loss_.notices.push_back(where_ + ": truncated at offset " + std::to_string(c.fileOffset()) + ": the last " +
                              std::to_string(c.remaining()) + " bytes hold no complete record and were not read");
      break;
    }
    try {
      const auto fields = headerFields(r.header, where_, r.offset);
      const auto op = field<std::uint8_t>(fields, "op", where_, r.offset);
      if (op == kConnection) onConnection(r, where_);
      if (op == kChunk) scanChunk(r);
    } catch (const Error& e) {
      skipChunk(r.offset, e.what());
    }
  }
  for (const auto& [conn, n] : counts_)
    if (const auto it = connection_topic_.find(conn); it != connection_topic_.end()) topics_[it->second].message_count += n;
}

Bytes Ros1BagReader::decodeChunk(const Record& r, std::vector<std::uint8_t>& buffer) {
  const std::string where = where_ + ": chunk at offset " + std::to_string(r.offset);
  const auto fields = headerFields(r.header, where_, r.offset);
  if (field<std::uint8_t>(fields, "op", where_, r.offset) != kChunk) fail(where, "not a chunk record");
  const std::string compression = textField(fields, "compression");
  const auto size = field<std::uint32_t>(fields, "size", where_, r.offset);
  Codec codec;
  if (compression == "none") {
    if (r.data.size() != size) fail(where, "holds " + std::to_string(r.data.size()) + " bytes, its header says " + std::to_string(size));
    return r.data;
  } else if (compression == "bz2") {
    codec = Codec::Bz2;
  } else if (compression == "lz4") {
    codec = Codec::Lz4Frame;
  } else {
    fail(where, "unsupported compression '" + compression + "' (none, bz2, lz4 are read)");
  }
  decompress(codec, r.data, size, buffer, where);
  return Bytes(buffer.data(), size);
}

void Ros1BagReader::scanChunk(const Record& r) {
  // Without the index, connections and message counts come from the chunks themselves.
  std::vector<std::uint8_t> buffer;
  const Bytes records = decodeChunk(r, buffer);
  const std::string where = where_ + ": chunk at offset " + std::to_string(r.offset);
  ByteCursor c(records, where);
  Record inner;
  std::int64_t first = INT64_MAX;
  while (!c.atEnd()) {
    if (!readRecord(c, inner)) c.failAt("record runs past the end of its chunk");
    const auto fields = headerFields(inner.header, where, inner.offset);
    const auto op = field<std::uint8_t>(fields, "op", where, inner.offset);
    if (op == kConnection) onConnection(inner, where);
    if (op != kMessageData) continue;
    const auto t = rosTime(field<std::uint64_t>(fields, "time", where, inner.offset));
    ++counts_[field<std::uint32_t>(fields, "conn", where, inner.offset)];
    extendRange(t);
    first = std::min(first, t);
  }
  if (first != INT64_MAX) blocks_.push_back({first, r.offset, 0});
}

void Ros1BagReader::loadBlock(const MergeBlock& b, std::vector<std::uint8_t>& buffer, std::vector<MergeEntry>& out) {
  if (bad_chunks_.count(b.offset)) return;
  try {
    ByteCursor c(file_.bytes(), where_);
    c.seek(b.offset);
    Record r;
    if (!readRecord(c, r)) c.failAt("no complete chunk record where the index points");
    const Bytes records = decodeChunk(r, buffer);
    const std::string where = where_ + ": chunk at offset " + std::to_string(b.offset);
    ByteCursor rc(records, where);
    Record inner;
    while (!rc.atEnd()) {
      if (!readRecord(rc, inner)) rc.failAt("record runs past the end of its chunk");
      const auto fields = headerFields(inner.header, where, inner.offset);
      if (field<std::uint8_t>(fields, "op", where, inner.offset) != kMessageData) continue;
      const auto conn = connection_topic_.find(field<std::uint32_t>(fields, "conn", where, inner.offset));
      if (conn == connection_topic_.end()) rc.failAt("message of an unknown connection");
      if (!selected_[conn->second]) continue;
      out.push_back({rosTime(field<std::uint64_t>(fields, "time", where, inner.offset)),
                     static_cast<std::uint32_t>(conn->second), inner.data});
    }
    checkEntryTimes(b, out, where);
  } catch (const Error& e) {
    out.clear();  // all or nothing
    skipChunk(b.offset, e.what());
  }
}

}  // namespace

std::unique_ptr<MessageReader> openRos1Bag(const std::filesystem::path& file) {
  return std::make_unique<Ros1BagReader>(file);
}

}  // namespace hazmap::sources
