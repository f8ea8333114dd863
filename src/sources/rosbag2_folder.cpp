// A rosbag2 folder: metadata.yaml names the storage plugin (sqlite3 or mcap) and the files, in
// recording order; a split bag's files are merged into one log-time stream.
#include <yaml-cpp/yaml.h>
#include <zstd.h>

#include <algorithm>
#include <fstream>
#include <sstream>

#include "bag_readers.hpp"
#include "compression.hpp"
#include "hazmap/core/error.hpp"

namespace hazmap::sources {
namespace fs = std::filesystem;
namespace {

struct Rosbag2Metadata {
  std::string storage;  // "sqlite3" or "mcap"
  std::vector<fs::path> files;
  std::string compression_format, compression_mode;
};

std::string scalar(const YAML::Node& node, const char* key) {
  const auto v = node[key];
  return v && v.IsScalar() ? v.as<std::string>() : std::string();
}

Rosbag2Metadata readMetadata(const fs::path& yaml_path) {
  const std::string where = yaml_path.string();
  std::ifstream in(yaml_path, std::ios::binary);
  if (!in) fail(where, "cannot open");
  std::stringstream text;
  text << in.rdbuf();
  YAML::Node info;
  try {
    info = YAML::Load(text.str())["rosbag2_bagfile_information"];
  } catch (const YAML::Exception& e) {
    fail(where, "invalid YAML: " + std::string(e.what()));
  }
  if (!info || !info.IsMap()) fail(where, "no rosbag2_bagfile_information map (not a rosbag2 metadata.yaml)");
  Rosbag2Metadata m;
  try {
    m.storage = scalar(info, "storage_identifier");
    m.compression_format = scalar(info, "compression_format");
    m.compression_mode = scalar(info, "compression_mode");
    const auto files = info["relative_file_paths"];
    if (files && files.IsSequence())
      for (const auto& f : files)
        if (f.IsScalar()) m.files.push_back(yaml_path.parent_path() / f.as<std::string>());
  } catch (const YAML::Exception& e) {
    fail(where, "invalid rosbag2 metadata: " + std::string(e.what()));
  }
  return m;
}

bool hasExtension(const fs::path& p, const char* ext) { return p.extension() == ext; }

/// A folder without metadata.yaml (rosbag2 can reindex those): its .db3 / .mcap files by name.
Rosbag2Metadata guessMetadata(const fs::path& dir) {
  Rosbag2Metadata m;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file()) continue;
    if (hasExtension(e.path(), ".db3") || hasExtension(e.path(), ".mcap")) m.files.push_back(e.path());
  }
  std::sort(m.files.begin(), m.files.end());
  if (m.files.empty()) fail(dir.string(), "no metadata.yaml and no .db3 or .mcap files (not a rosbag2 folder)");
  return m;
}

/// rosbag2's message compression mode: each message's data is one zstd frame.
class ZstdMessagesReader final : public MessageReader {
 public:
  ZstdMessagesReader(std::unique_ptr<MessageReader> inner, std::string where)
      : inner_(std::move(inner)), where_(std::move(where)) {}
  const std::vector<TopicInfo>& topics() const override { return inner_->topics(); }
  void selectTopics(const std::vector<std::string>& names) override { inner_->selectTopics(names); }
  std::pair<std::int64_t, std::int64_t> timeRange() const override { return inner_->timeRange(); }
  bool next(BagMessage& message) override {
    while (inner_->next(message)) {
      const std::string where = where_ + ": message at " + std::to_string(message.log_time_ns) + " ns on " + message.topic->name;
      try {
        const unsigned long long size = ZSTD_getFrameContentSize(message.data.data(), message.data.size());
        if (size == ZSTD_CONTENTSIZE_ERROR || size == ZSTD_CONTENTSIZE_UNKNOWN)
          fail(where, "not a zstd frame with its content size");
        decompress(Codec::Zstd, message.data, size, buffer_, where);
        message.data = std::span<const std::uint8_t>(buffer_.data(), static_cast<std::size_t>(size));
        syncLoss();
        return true;
      } catch (const Error& e) {
        loss_.notices.push_back(std::string(e.what()) + "; message skipped");
      }
    }
    syncLoss();
    return false;
  }

 private:
  void syncLoss() {
    const BagLoss& inner = inner_->loss();
    loss_.bytes_unread = inner.bytes_unread;
    loss_.chunks_skipped = inner.chunks_skipped;
    for (std::size_t i = inner_notices_; i < inner.notices.size(); ++i) loss_.notices.push_back(inner.notices[i]);
    inner_notices_ = inner.notices.size();
  }
  std::unique_ptr<MessageReader> inner_;
  std::string where_;
  std::vector<std::uint8_t> buffer_;
  std::size_t inner_notices_ = 0;
};

std::unique_ptr<MessageReader> openStorageFile(const fs::path& file, const std::string& storage) {
  if (storage == "mcap" || (storage.empty() && hasExtension(file, ".mcap"))) return openMcap(file);
  if (storage == "sqlite3" || storage.empty()) return openDb3(file);
  fail(file.string(), "unsupported rosbag2 storage '" + storage + "' (sqlite3 and mcap are read)");
}

}  // namespace

std::unique_ptr<MessageReader> openRosbag2(const fs::path& path) {
  if (fs::is_regular_file(path)) {
    if (path.filename() == "metadata.yaml") return openRosbag2(path.parent_path());
    return openDb3(path);
  }
  const fs::path yaml_path = path / "metadata.yaml";
  const Rosbag2Metadata meta = fs::exists(yaml_path) ? readMetadata(yaml_path) : guessMetadata(path);
  const bool zstd_messages = meta.compression_format == "zstd" && (meta.compression_mode == "MESSAGE" || meta.compression_mode == "message");
  if (!meta.compression_format.empty() && !zstd_messages)
    fail(yaml_path.string(), "compressed rosbag2 (" + meta.compression_format + ", mode " + meta.compression_mode +
                                 ") is not read (zstd per message is); decompress it with `ros2 bag convert`");
  if (meta.files.empty()) fail(yaml_path.string(), "relative_file_paths lists no storage files");
  std::vector<std::unique_ptr<MessageReader>> readers;
  for (const auto& f : meta.files) {
    std::error_code ec;  // a listed name can be unusable (too long, bad bytes): say so, never throw
    if (!fs::exists(f, ec))
      fail(yaml_path.string(), "lists " + f.filename().string() + (ec ? ", which cannot be opened: " + ec.message() : ", which is missing"));
    readers.push_back(openStorageFile(f, meta.storage));
  }
  auto reader = readers.size() == 1 ? std::move(readers.front()) : mergeReaders(std::move(readers));
  if (zstd_messages) return std::make_unique<ZstdMessagesReader>(std::move(reader), path.string());
  return reader;
}

}  // namespace hazmap::sources
