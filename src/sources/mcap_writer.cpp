// MCAP writer: records are built in memory (a chunk at a time), the file is written through an
// AtomicFile and only renamed into place by close().
#include "hazmap/sources/mcap_writer.hpp"

#include <algorithm>
#include <cstring>

#include "compression.hpp"
#include "bag_readers.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "mcap_format.hpp"

namespace hazmap {
namespace {

using namespace sources::mcap;

/// Little-endian record builder.
struct Bytes {
  std::vector<std::uint8_t> b;
  template <class T>
  void put(T v) {
    const std::size_t at = b.size();
    b.resize(at + sizeof(T));
    std::memcpy(b.data() + at, &v, sizeof(T));
  }
  // Out of line: inlined into str(), GCC 12 warns about the short-string buffer (bogus).
  [[gnu::noinline]] void raw(const void* data, std::size_t n) {
    if (n == 0) return;
    const auto* p = static_cast<const std::uint8_t*>(data);
    b.insert(b.end(), p, p + n);
  }
  void str(const std::string& s) {
    put<std::uint32_t>(static_cast<std::uint32_t>(s.size()));
    raw(s.data(), s.size());
  }
  void raw(std::span<const std::uint8_t> s) { raw(s.data(), s.size()); }
  /// opcode + u64 length + body
  void record(std::uint8_t opcode, const Bytes& body) {
    put<std::uint8_t>(opcode);
    put<std::uint64_t>(body.b.size());
    raw(body.b);
  }
};

struct SchemaInfo {
  std::string name, encoding, data;
};
struct ChannelInfo {
  std::uint16_t schema;
  std::string topic, encoding;
};
struct ChunkIndexInfo {
  std::uint64_t start, end, offset, length, index_length, compressed, uncompressed;
  std::map<std::uint16_t, std::uint64_t> index_offsets;
};

Bytes schemaRecord(std::uint16_t id, const SchemaInfo& s) {
  Bytes r;
  r.put<std::uint16_t>(id);
  r.str(s.name);
  r.str(s.encoding);
  r.put<std::uint32_t>(static_cast<std::uint32_t>(s.data.size()));
  r.raw(s.data.data(), s.data.size());
  return r;
}

Bytes channelRecord(std::uint16_t id, const ChannelInfo& c) {
  Bytes r;
  r.put<std::uint16_t>(id);
  r.put<std::uint16_t>(c.schema);
  r.str(c.topic);
  r.str(c.encoding);
  r.put<std::uint32_t>(0);  // metadata: empty map
  return r;
}

const char* compressionName(McapCompression c) {
  return c == McapCompression::Zstd ? "zstd" : c == McapCompression::Lz4 ? "lz4" : "";
}

}  // namespace

struct McapWriter::Impl {
  McapWriterOptions options;
  AtomicFile file;
  std::string where;
  std::uint64_t offset = 0;  // bytes written so far
  std::vector<SchemaInfo> schemas;   // id = index + 1
  std::vector<ChannelInfo> channels;  // id = index
  std::map<std::string, std::uint16_t> ros_schemas;
  std::vector<bool> channel_in_file;  // its Schema/Channel records already written
  std::vector<bool> schema_in_file;
  // current chunk
  Bytes chunk;
  std::uint64_t chunk_start = UINT64_MAX, chunk_end = 0;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index;
  // summary
  std::vector<ChunkIndexInfo> chunk_indexes;
  std::map<std::uint16_t, std::uint64_t> channel_counts;
  std::uint64_t message_count = 0, message_start = UINT64_MAX, message_end = 0;
  bool closed = false;

  Impl(const std::filesystem::path& path, McapWriterOptions o)
      : options(std::move(o)), file(path), where(path.string()) {}

  void emit(std::span<const std::uint8_t> bytes) {
    file.stream().write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    if (!file.stream()) fail(where, "write failed (disk full?)");
    offset += bytes.size();
  }
  void emitRecord(std::uint8_t opcode, const Bytes& body) {
    Bytes r;
    r.record(opcode, body);
    emit(r.b);
  }
  void start() {
    emit(std::span(sources::kMcapMagic, 8));
    Bytes header;
    header.str(options.profile);
    header.str(options.library);
    emitRecord(kHeader, header);
  }
  void flushChunk();
  void writeMessageIndexes(ChunkIndexInfo& info);
  Bytes summary(std::vector<std::pair<std::uint8_t, std::pair<std::uint64_t, std::uint64_t>>>& groups,
                std::uint64_t summary_start);
  void finish();
};

void McapWriter::Impl::flushChunk() {
  if (chunk.b.empty()) return;
  const std::vector<std::uint8_t>& records = chunk.b;
  std::vector<std::uint8_t> compressed;
  std::span<const std::uint8_t> stored = records;
  if (options.compression == McapCompression::Zstd) {
    compressed = sources::compressZstd(records, options.zstd_level);
    stored = compressed;
  } else if (options.compression == McapCompression::Lz4) {
    compressed = sources::compressLz4Frame(records);
    stored = compressed;
  }
  Bytes body;
  body.put<std::uint64_t>(chunk_start == UINT64_MAX ? 0 : chunk_start);
  body.put<std::uint64_t>(chunk_end);
  body.put<std::uint64_t>(records.size());
  body.put<std::uint32_t>(sources::crc32(records));
  body.str(compressionName(options.compression));
  body.put<std::uint64_t>(stored.size());
  body.raw(stored);
  ChunkIndexInfo info{chunk_start == UINT64_MAX ? 0 : chunk_start, chunk_end, offset, 0, 0, stored.size(), records.size(), {}};
  emitRecord(kChunk, body);
  info.length = offset - info.offset;
  writeMessageIndexes(info);
  chunk_indexes.push_back(std::move(info));
  chunk.b.clear();
  chunk_index.clear();
  chunk_start = UINT64_MAX;
  chunk_end = 0;
}

void McapWriter::Impl::writeMessageIndexes(ChunkIndexInfo& info) {
  const std::uint64_t start = offset;
  for (auto& [channel, entries] : chunk_index) {
    std::stable_sort(entries.begin(), entries.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    Bytes body;
    body.put<std::uint16_t>(channel);
    body.put<std::uint32_t>(static_cast<std::uint32_t>(entries.size() * 16));
    for (const auto& [time, at] : entries) {
      body.put<std::uint64_t>(time);
      body.put<std::uint64_t>(at);
    }
    info.index_offsets[channel] = offset;
    emitRecord(kMessageIndex, body);
  }
  info.index_length = offset - start;
}

Bytes McapWriter::Impl::summary(std::vector<std::pair<std::uint8_t, std::pair<std::uint64_t, std::uint64_t>>>& groups,
                                std::uint64_t summary_start) {
  Bytes s;
  auto group = [&](std::uint8_t opcode, auto&& write_records) {
    const std::uint64_t begin = s.b.size();
    write_records();
    if (s.b.size() > begin) groups.push_back({opcode, {summary_start + begin, s.b.size() - begin}});
  };
  group(kSchema, [&] {
    for (std::size_t i = 0; i < schemas.size(); ++i) s.record(kSchema, schemaRecord(static_cast<std::uint16_t>(i + 1), schemas[i]));
  });
  group(kChannel, [&] {
    for (std::size_t i = 0; i < channels.size(); ++i) s.record(kChannel, channelRecord(static_cast<std::uint16_t>(i), channels[i]));
  });
  group(kStatistics, [&] {
    Bytes st;
    st.put<std::uint64_t>(message_count);
    st.put<std::uint16_t>(static_cast<std::uint16_t>(schemas.size()));
    st.put<std::uint32_t>(static_cast<std::uint32_t>(channels.size()));
    st.put<std::uint32_t>(0);  // attachments
    st.put<std::uint32_t>(0);  // metadata
    st.put<std::uint32_t>(static_cast<std::uint32_t>(chunk_indexes.size()));
    st.put<std::uint64_t>(message_count ? message_start : 0);
    st.put<std::uint64_t>(message_end);
    st.put<std::uint32_t>(static_cast<std::uint32_t>(channel_counts.size() * 10));
    for (const auto& [id, n] : channel_counts) st.put<std::uint16_t>(id), st.put<std::uint64_t>(n);
    s.record(kStatistics, st);
  });
  group(kChunkIndex, [&] {
    for (const auto& c : chunk_indexes) {
      Bytes ci;
      ci.put<std::uint64_t>(c.start);
      ci.put<std::uint64_t>(c.end);
      ci.put<std::uint64_t>(c.offset);
      ci.put<std::uint64_t>(c.length);
      ci.put<std::uint32_t>(static_cast<std::uint32_t>(c.index_offsets.size() * 10));
      for (const auto& [id, at] : c.index_offsets) ci.put<std::uint16_t>(id), ci.put<std::uint64_t>(at);
      ci.put<std::uint64_t>(c.index_length);
      ci.str(compressionName(options.compression));
      ci.put<std::uint64_t>(c.compressed);
      ci.put<std::uint64_t>(c.uncompressed);
      s.record(kChunkIndex, ci);
    }
  });
  return s;
}

void McapWriter::Impl::finish() {
  flushChunk();
  Bytes data_end;
  data_end.put<std::uint32_t>(0);  // data section CRC not computed (allowed by the spec)
  emitRecord(kDataEnd, data_end);
  const std::uint64_t summary_start = offset;
  std::vector<std::pair<std::uint8_t, std::pair<std::uint64_t, std::uint64_t>>> groups;
  Bytes tail = summary(groups, summary_start);
  const std::uint64_t summary_offset_start = summary_start + tail.b.size();
  for (const auto& [opcode, range] : groups) {
    Bytes so;
    so.put<std::uint8_t>(opcode);
    so.put<std::uint64_t>(range.first);
    so.put<std::uint64_t>(range.second);
    tail.record(kSummaryOffset, so);
  }
  // The footer's CRC covers the summary, the summary offsets and the footer up to the CRC.
  tail.put<std::uint8_t>(kFooter);
  tail.put<std::uint64_t>(kFooterBody);
  tail.put<std::uint64_t>(summary_start);
  tail.put<std::uint64_t>(summary_offset_start);
  tail.put<std::uint32_t>(sources::crc32(tail.b));
  tail.raw(std::span(sources::kMcapMagic, 8));
  emit(tail.b);
}

McapWriter::McapWriter(const std::filesystem::path& path, McapWriterOptions options)
    : impl_(std::make_unique<Impl>(path, std::move(options))) {
  impl_->start();
}

McapWriter::~McapWriter() = default;

std::uint16_t McapWriter::addSchema(const std::string& name, const std::string& encoding, const std::string& data) {
  if (impl_->schemas.size() >= 65535) fail(impl_->where, "too many schemas");
  impl_->schemas.push_back({name, encoding, data});
  impl_->schema_in_file.push_back(false);
  return static_cast<std::uint16_t>(impl_->schemas.size());
}

std::uint16_t McapWriter::addChannel(const std::string& topic, std::uint16_t schema_id, const std::string& message_encoding) {
  if (schema_id > impl_->schemas.size()) fail(impl_->where, "channel " + topic + " names unknown schema " + std::to_string(schema_id));
  if (impl_->channels.size() >= 65535) fail(impl_->where, "too many channels");
  impl_->channels.push_back({schema_id, topic, message_encoding});
  impl_->channel_in_file.push_back(false);
  return static_cast<std::uint16_t>(impl_->channels.size() - 1);
}

std::uint16_t McapWriter::addRosChannel(const std::string& topic, const std::string& ros2_type) {
  auto it = impl_->ros_schemas.find(ros2_type);
  if (it == impl_->ros_schemas.end())
    it = impl_->ros_schemas.emplace(ros2_type, addSchema(ros2_type, "ros2msg", ros2MessageDefinition(ros2_type))).first;
  return addChannel(topic, it->second, "cdr");
}

void McapWriter::write(std::uint16_t channel, std::int64_t log_time_ns, std::span<const std::uint8_t> data,
                       std::int64_t publish_time_ns) {
  Impl& m = *impl_;
  if (m.closed) fail(m.where, "write after close");
  if (channel >= m.channels.size()) fail(m.where, "write to unknown channel " + std::to_string(channel));
  if (log_time_ns < 0) fail(m.where, "negative log time " + std::to_string(log_time_ns));
  if (!m.channel_in_file[channel]) {  // a chunk declares the schema and channel it first uses
    const std::uint16_t schema = m.channels[channel].schema;
    if (schema != 0 && !m.schema_in_file[schema - 1]) {
      m.chunk.record(kSchema, schemaRecord(schema, m.schemas[schema - 1]));
      m.schema_in_file[schema - 1] = true;
    }
    m.chunk.record(kChannel, channelRecord(channel, m.channels[channel]));
    m.channel_in_file[channel] = true;
  }
  const auto t = static_cast<std::uint64_t>(log_time_ns);
  m.chunk_index[channel].emplace_back(t, m.chunk.b.size());
  Bytes body;
  body.put<std::uint16_t>(channel);
  body.put<std::uint32_t>(static_cast<std::uint32_t>(m.message_count));
  body.put<std::uint64_t>(t);
  body.put<std::uint64_t>(static_cast<std::uint64_t>(publish_time_ns < 0 ? log_time_ns : publish_time_ns));
  m.chunk.put<std::uint8_t>(kMessage);
  m.chunk.put<std::uint64_t>(body.b.size() + data.size());
  m.chunk.raw(body.b);
  m.chunk.raw(data);
  m.chunk_start = std::min(m.chunk_start, t);
  m.chunk_end = std::max(m.chunk_end, t);
  m.message_start = std::min(m.message_start, t);
  m.message_end = std::max(m.message_end, t);
  ++m.message_count;
  ++m.channel_counts[channel];
  if (m.chunk.b.size() >= m.options.chunk_size) m.flushChunk();
}

void McapWriter::close() {
  if (impl_->closed) return;
  impl_->finish();
  impl_->file.commit();
  impl_->closed = true;
}

}  // namespace hazmap
