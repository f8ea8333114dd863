// MCAP reader written from the specification (https://mcap.dev/spec). With a summary (chunk
// indexes) the chunks are visited through their index; without one (a streaming writer, a
// recorder killed before the footer) the data section is scanned record by record up to the
// last complete record. Chunks are loaded in start-time order and merged by log time; a chunk
// whose CRC or decompression fails is reported with its offset and skipped, never decoded.
#include <algorithm>
#include <cstring>
#include <map>
#include <set>

#include "bag_readers.hpp"
#include "block_merge.hpp"
#include "chunked_bag_reader.hpp"
#include "byte_cursor.hpp"
#include "compression.hpp"
#include "hazmap/core/error.hpp"
#include "mapped_file.hpp"
#include "mcap_format.hpp"

namespace hazmap::sources {
namespace {

using namespace mcap;
using Bytes = std::span<const std::uint8_t>;

enum BlockTag : std::uint32_t { kTopLevelMessage = 0, kChunkBlock = 1 };

std::int64_t toTime(std::uint64_t t) {
  return t > static_cast<std::uint64_t>(INT64_MAX) ? INT64_MAX : static_cast<std::int64_t>(t);
}

std::string hex(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08x", v);
  return buf;
}

struct Record {
  std::uint8_t opcode = 0;
  std::uint64_t offset = 0;  ///< of the opcode
  Bytes body;
};

/// Reads the record at the cursor; false (cursor unchanged) if it does not fit in what is left.
bool readRecord(ByteCursor& c, Record& r) {
  if (c.remaining() < kRecordPrefix) return false;
  const std::size_t start = c.position();
  r.offset = c.fileOffset();
  r.opcode = c.read<std::uint8_t>();
  const auto length = c.read<std::uint64_t>();
  if (length > c.remaining()) {
    c.seek(start);
    return false;
  }
  r.body = c.bytes(length);
  return true;
}

struct ChunkRecord {
  std::int64_t start = 0, end = 0;
  std::uint64_t uncompressed_size = 0;
  std::uint32_t crc = 0;
  std::string compression;
  Bytes records;
};

ChunkRecord parseChunk(const Record& r, const std::string& where) {
  ByteCursor c(r.body, where, r.offset + kRecordPrefix);
  ChunkRecord k;
  k.start = toTime(c.read<std::uint64_t>());
  k.end = toTime(c.read<std::uint64_t>());
  k.uncompressed_size = c.read<std::uint64_t>();
  k.crc = c.read<std::uint32_t>();
  k.compression = c.lengthString("compression");
  k.records = c.bytes(c.read<std::uint64_t>(), "chunk records");
  return k;
}

Codec codecOf(const std::string& name, const std::string& where) {
  if (name.empty()) return Codec::None;
  if (name == "zstd") return Codec::Zstd;
  if (name == "lz4") return Codec::Lz4Frame;
  fail(where, "unsupported chunk compression '" + name + "'");
}

class McapReader final : public ChunkedBagReader {
 public:
  explicit McapReader(const std::filesystem::path& path) : ChunkedBagReader(path.string()), file_(path) {
    const Bytes bytes = file_.bytes();
    if (bytes.size() < kMagicSize || std::memcmp(bytes.data(), kMcapMagic, kMagicSize) != 0)
      fail(where_, "not an MCAP file (no magic bytes at offset 0)");
    if (!readSummary()) linearScan();
    buildTopics();
  }

 private:
  struct Channel {
    std::uint16_t schema = 0;
    std::string topic, encoding;
    std::uint64_t count = 0;
    std::int32_t topic_index = -1;
  };
  struct Schema {
    std::string name, encoding, data;
  };

  // ---- records shared by the data and summary sections ----------------------------------
  void onSchema(const Record& r) {
    ByteCursor c(r.body, where_, r.offset + kRecordPrefix);
    const auto id = c.read<std::uint16_t>();
    Schema s;
    s.name = c.lengthString("schema name");
    s.encoding = c.lengthString("schema encoding");
    const auto data = c.bytes(c.read<std::uint32_t>(), "schema data");
    s.data.assign(data.begin(), data.end());
    if (id != 0) schemas_.try_emplace(id, std::move(s));
  }
  void onChannel(const Record& r) {
    ByteCursor c(r.body, where_, r.offset + kRecordPrefix);
    const auto id = c.read<std::uint16_t>();
    Channel ch;
    ch.schema = c.read<std::uint16_t>();
    ch.topic = c.lengthString("topic");
    ch.encoding = c.lengthString("message encoding");
    channels_.try_emplace(id, std::move(ch));
  }
  /// Schemas, channels and message counts inside a chunk (linear scan without a summary).
  void scanChunkRecords(Bytes records, std::uint64_t chunk_offset, bool count_messages) {
    ByteCursor c(records, where_ + ": chunk at offset " + std::to_string(chunk_offset));
    Record r;
    while (!c.atEnd()) {
      if (!readRecord(c, r)) c.failAt("record runs past the end of its chunk");
      if (r.opcode == kSchema) onSchema(r);
      if (r.opcode == kChannel) onChannel(r);
      if (r.opcode == kMessage && count_messages) countMessage(r, c.where());
    }
  }
  void countMessage(const Record& r, const std::string& where) {
    ByteCursor c(r.body, where, r.offset);
    const auto channel = c.read<std::uint16_t>();
    c.read<std::uint32_t>();
    const auto time = toTime(c.read<std::uint64_t>());
    ++channels_[channel].count;
    extendRange(time);
  }

  // ---- summary --------------------------------------------------------------------------
  bool readSummary();
  void readSummaryRecord(const Record& r, bool& has_statistics);
  void countFromMessageIndexes(const std::map<std::uint16_t, std::uint64_t>& offsets);
  // ---- linear scan ----------------------------------------------------------------------
  void linearScan();
  void prescanChunk(const Record& r);
  // ---- reading --------------------------------------------------------------------------
  void buildTopics();
  void loadBlock(const MergeBlock& b, std::vector<std::uint8_t>& buffer, std::vector<MergeEntry>& out) override;
  void loadChunk(const MergeBlock& b, std::vector<std::uint8_t>& buffer, std::vector<MergeEntry>& out);
  Bytes decodeChunk(const Record& r, std::vector<std::uint8_t>& buffer);
  void addMessage(const Record& r, const std::string& where, std::vector<MergeEntry>& out);

  void unknownChannel(std::uint16_t channel) {
    // Without a summary a channel is declared only in the chunk where it was first used; if
    // that chunk was skipped its later messages cannot be attributed: say so, once.
    if (!unknown_channels_.insert(channel).second) return;
    loss_.notices.push_back(where_ + ": messages of channel " + std::to_string(channel) +
                            " skipped: its Channel record is missing (in a skipped chunk?)");
  }

  MappedFile file_;
  std::set<std::uint16_t> unknown_channels_;
  std::map<std::uint16_t, Schema> schemas_;
  std::map<std::uint16_t, Channel> channels_;
  std::vector<std::int32_t> channel_topic_ = std::vector<std::int32_t>(65536, -1);
};

bool McapReader::readSummary() {
  const Bytes bytes = file_.bytes();
  const std::uint64_t tail = kRecordPrefix + kFooterBody + kMagicSize;
  if (bytes.size() < kMagicSize + tail) return false;
  if (std::memcmp(bytes.data() + bytes.size() - kMagicSize, kMcapMagic, kMagicSize) != 0) return false;
  const std::uint64_t footer_at = bytes.size() - tail;
  ByteCursor f(bytes, where_);
  f.seek(footer_at);
  if (f.read<std::uint8_t>() != kFooter || f.read<std::uint64_t>() != kFooterBody) return false;
  const auto summary_start = f.read<std::uint64_t>();
  const auto summary_offset_start = f.read<std::uint64_t>();
  const auto summary_crc = f.read<std::uint32_t>();
  if (summary_start == 0) return false;  // no summary: scan
  if (summary_start < kMagicSize || summary_start > footer_at ||
      (summary_offset_start != 0 && (summary_offset_start < summary_start || summary_offset_start > footer_at))) {
    loss_.notices.push_back(where_ + ": footer points outside the file (summary at " + std::to_string(summary_start) + "); scanning the data section");
    return false;
  }
  if (summary_crc != 0) {
    const auto computed = crc32(bytes.subspan(summary_start, footer_at + kRecordPrefix + 16 - summary_start));
    if (computed != summary_crc) {
      loss_.notices.push_back(where_ + ": summary CRC mismatch at offset " + std::to_string(summary_start) + "; scanning the data section");
      return false;
    }
  }
  const std::uint64_t summary_end = summary_offset_start ? summary_offset_start : footer_at;
  ByteCursor c(bytes.subspan(0, summary_end), where_);
  c.seek(summary_start);
  bool has_statistics = false;
  try {
    Record r;
    while (!c.atEnd()) {
      if (!readRecord(c, r)) c.failAt("summary record runs past the summary section");
      readSummaryRecord(r, has_statistics);
    }
  } catch (const Error& e) {
    loss_.notices.push_back(std::string(e.what()) + "; scanning the data section");
    schemas_.clear(), channels_.clear(), blocks_.clear(), any_time_ = false;
    return false;
  }
  const bool declares_channels = std::any_of(channels_.begin(), channels_.end(),
                                             [](const auto& c) { return !c.second.topic.empty(); });
  // A summary without chunk indexes, or without the Channel records (a writer that does not
  // repeat them): the messages and channels are found by a scan.
  if (blocks_.empty() || !declares_channels) {
    blocks_.clear();
    channels_.clear();
    any_time_ = false;
    return false;
  }
  return true;
}

void McapReader::readSummaryRecord(const Record& r, bool& has_statistics) {
  ByteCursor c(r.body, where_, r.offset + kRecordPrefix);
  if (r.opcode == kSchema) onSchema(r);
  if (r.opcode == kChannel) onChannel(r);
  if (r.opcode == kStatistics) {
    c.skip(8 + 2 + 4 + 4 + 4 + 4);
    const auto t0 = toTime(c.read<std::uint64_t>()), t1 = toTime(c.read<std::uint64_t>());
    const auto map_bytes = c.read<std::uint32_t>();
    ByteCursor m(c.bytes(map_bytes, "channel message counts"), where_, c.fileOffset() - map_bytes);
    while (!m.atEnd()) {
      const auto id = m.read<std::uint16_t>();
      channels_[id].count = m.read<std::uint64_t>();
    }
    range_ = {t0, t1};
    any_time_ = has_statistics = true;
  }
  if (r.opcode == kChunkIndex) {
    const auto t0 = toTime(c.read<std::uint64_t>()), t1 = toTime(c.read<std::uint64_t>());
    const auto chunk_offset = c.read<std::uint64_t>();
    const auto chunk_length = c.read<std::uint64_t>();
    if (chunk_offset < kMagicSize || chunk_offset > file_.size() || chunk_length > file_.size() - chunk_offset)
      c.failAt("chunk index points outside the file (chunk at " + std::to_string(chunk_offset) + ")");
    const auto map_bytes = c.read<std::uint32_t>();
    ByteCursor m(c.bytes(map_bytes, "message index offsets"), where_);
    std::map<std::uint16_t, std::uint64_t> offsets;
    while (!m.atEnd()) {
      const auto id = m.read<std::uint16_t>();
      offsets[id] = m.read<std::uint64_t>();
    }
    blocks_.push_back({t0, chunk_offset, kChunkBlock});
    if (!has_statistics) {
      countFromMessageIndexes(offsets);
      if (t0 <= t1) extendRange(t0), extendRange(t1);
    }
  }
}

void McapReader::countFromMessageIndexes(const std::map<std::uint16_t, std::uint64_t>& offsets) {
  // Only without a Statistics record (which comes before chunk indexes when written).
  for (const auto& [id, offset] : offsets) {
    if (offset >= file_.size()) continue;
    ByteCursor c(file_.bytes(), where_);
    c.seek(offset);
    Record r;
    if (!readRecord(c, r) || r.opcode != kMessageIndex || r.body.size() < 6) continue;
    ByteCursor m(r.body, where_, r.offset);
    m.read<std::uint16_t>();
    channels_[id].count += m.read<std::uint32_t>() / 16;
  }
}

void McapReader::linearScan() {
  const Bytes bytes = file_.bytes();
  ByteCursor c(bytes, where_);
  c.seek(kMagicSize);
  Record r;
  while (!c.atEnd()) {
    if (!readRecord(c, r)) {
      loss_.bytes_unread = c.remaining();
      loss_.notices.push_back(where_ + ": truncated at offset " + std::to_string(c.fileOffset()) + ": the last " +
                              std::to_string(c.remaining()) + " bytes hold no complete record and were not read");
      return;
    }
    if (r.opcode == kDataEnd || r.opcode == kFooter) return;
    try {
      if (r.opcode == kSchema) onSchema(r);
      if (r.opcode == kChannel) onChannel(r);
      if (r.opcode == kMessage) {
        countMessage(r, where_);
        ByteCursor m(r.body, where_, r.offset);
        m.skip(6);
        blocks_.push_back({toTime(m.read<std::uint64_t>()), r.offset, kTopLevelMessage});
      }
      if (r.opcode == kChunk) prescanChunk(r);
    } catch (const Error& e) {
      if (r.opcode == kChunk) {
        skipChunk(r.offset, e.what());
      } else {
        loss_.notices.push_back(std::string(e.what()) + "; record skipped");
      }
    }
  }
}

void McapReader::prescanChunk(const Record& r) {
  // Without a summary the schemas and channels live inside the chunks: decompress each once
  // (checking its CRC) to learn them and to count messages.
  std::vector<std::uint8_t> buffer;
  const Bytes records = decodeChunk(r, buffer);
  scanChunkRecords(records, r.offset, true);
  blocks_.push_back({parseChunk(r, where_).start, r.offset, kChunkBlock});
}

Bytes McapReader::decodeChunk(const Record& r, std::vector<std::uint8_t>& buffer) {
  const ChunkRecord k = parseChunk(r, where_);
  const std::string where = where_ + ": chunk at offset " + std::to_string(r.offset);
  const Codec codec = codecOf(k.compression, where);
  Bytes records = k.records;
  if (codec != Codec::None) {
    decompress(codec, k.records, k.uncompressed_size, buffer, where);
    records = Bytes(buffer.data(), static_cast<std::size_t>(k.uncompressed_size));
  } else if (k.records.size() != k.uncompressed_size) {
    fail(where, "uncompressed chunk of " + std::to_string(k.records.size()) + " bytes, header says " +
                    std::to_string(k.uncompressed_size));
  }
  if (k.crc != 0) {
    const auto computed = crc32(records);
    if (computed != k.crc) fail(where, "CRC mismatch (stored " + hex(k.crc) + ", computed " + hex(computed) + ")");
  }
  return records;
}

void McapReader::buildTopics() {
  std::map<std::pair<std::string, std::string>, std::size_t> by_topic_and_type;
  for (auto& [id, ch] : channels_) {
    if (ch.topic.empty() && ch.encoding.empty()) continue;  // counted, never declared
    const auto schema = schemas_.find(ch.schema);
    const std::string type = schema == schemas_.end() ? "" : ros2TypeName(schema->second.name);
    const auto [it, fresh] = by_topic_and_type.try_emplace({ch.topic, type}, topics_.size());
    if (fresh) {
      TopicInfo t;
      t.name = ch.topic;
      t.type = type;
      t.serialization = serializationFromName(ch.encoding);
      if (schema != schemas_.end()) t.definition = schema->second.data;
      topics_.push_back(std::move(t));
    }
    topics_[it->second].message_count += ch.count;
    channel_topic_[id] = static_cast<std::int32_t>(it->second);
  }
  selected_.assign(topics_.size(), 1);
}

void McapReader::loadBlock(const MergeBlock& b, std::vector<std::uint8_t>& buffer, std::vector<MergeEntry>& out) {
  if (b.tag == kChunkBlock) return loadChunk(b, buffer, out);
  ByteCursor c(file_.bytes(), where_);
  c.seek(b.offset);
  Record r;
  if (readRecord(c, r)) addMessage(r, where_, out);
}

void McapReader::loadChunk(const MergeBlock& b, std::vector<std::uint8_t>& buffer, std::vector<MergeEntry>& out) {
  if (bad_chunks_.count(b.offset)) return;
  try {
    ByteCursor c(file_.bytes(), where_);
    c.seek(b.offset);
    Record r;
    if (!readRecord(c, r) || r.opcode != kChunk) c.failAt("no complete chunk record where the index points");
    const Bytes records = decodeChunk(r, buffer);
    ByteCursor rc(records, where_ + ": chunk at offset " + std::to_string(b.offset));
    Record inner;
    while (!rc.atEnd()) {
      if (!readRecord(rc, inner)) rc.failAt("record runs past the end of its chunk");
      if (inner.opcode == kMessage) addMessage(inner, rc.where(), out);
    }
    checkEntryTimes(b, out, where_);
  } catch (const Error& e) {
    out.clear();  // all or nothing: a chunk that does not parse is not half-used
    skipChunk(b.offset, e.what());
  }
}

void McapReader::addMessage(const Record& r, const std::string& where, std::vector<MergeEntry>& out) {
  ByteCursor c(r.body, where, r.offset);
  if (r.body.size() < kMessagePrefix) c.failAt("message record shorter than its fixed fields");
  const auto channel = c.read<std::uint16_t>();
  c.read<std::uint32_t>();
  const auto log_time = toTime(c.read<std::uint64_t>());
  c.read<std::uint64_t>();
  const std::int32_t topic = channel_topic_[channel];
  if (topic < 0) return unknownChannel(channel);
  if (!selected_[static_cast<std::size_t>(topic)]) return;
  out.push_back({log_time, static_cast<std::uint32_t>(topic), r.body.subspan(kMessagePrefix)});
}

}  // namespace

std::unique_ptr<MessageReader> openMcap(const std::filesystem::path& file) {
  return std::make_unique<McapReader>(file);
}

}  // namespace hazmap::sources
