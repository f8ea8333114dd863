// One rosbag2 sqlite3 storage file: the topics table (name, type, serialization_format) and
// the messages table (topic_id, timestamp, data) read in timestamp order.
#include <sqlite3.h>

#include <algorithm>
#include <map>

#include "bag_readers.hpp"
#include "hazmap/core/error.hpp"

namespace hazmap::sources {
namespace {

/// sqlite URI of a read-only, immutable file (no locks or journal, works on read-only media).
std::string immutableUri(const std::filesystem::path& file) {
  std::string uri = "file:";
  for (const char c : std::filesystem::absolute(file).string()) {
    if (c == '?' || c == '#' || c == '%') {
      static const char* hex = "0123456789ABCDEF";
      uri += '%';
      uri += hex[(c >> 4) & 15];
      uri += hex[c & 15];
    } else {
      uri += c;
    }
  }
  return uri + "?immutable=1";
}

class Db3Reader final : public MessageReader {
 public:
  explicit Db3Reader(const std::filesystem::path& file) : where_(file.string()) {
    if (!std::filesystem::is_regular_file(file)) fail(where_, "no such sqlite3 file");
    if (sqlite3_open_v2(immutableUri(file).c_str(), &db_, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI,
                        nullptr) != SQLITE_OK) {
      const std::string msg = db_ ? sqlite3_errmsg(db_) : "cannot open";
      sqlite3_close(db_);
      fail(where_, "sqlite3: " + msg);
    }
    try {
      readTopics();
      readCountsAndRange();
    } catch (...) {
      sqlite3_close(db_);
      throw;
    }
  }
  ~Db3Reader() override {
    sqlite3_finalize(messages_);
    sqlite3_close(db_);
  }

  const std::vector<TopicInfo>& topics() const override { return topics_; }
  void selectTopics(const std::vector<std::string>& names) override { selected_ = names; }
  std::pair<std::int64_t, std::int64_t> timeRange() const override { return range_; }

  bool next(BagMessage& message) override {
    if (done_) return false;
    if (!messages_) prepareMessages();
    const int rc = sqlite3_step(messages_);
    if (rc == SQLITE_DONE) return done_ = true, false;
    if (rc != SQLITE_ROW) {
      // A damaged file (recorder killed, disk full): keep what was read, say where it stopped.
      loss_.notices.push_back(where_ + ": sqlite3 stopped after " + std::to_string(read_) +
                              " messages: " + sqlite3_errmsg(db_));
      return done_ = true, false;
    }
    const auto topic = topic_by_id_.find(sqlite3_column_int64(messages_, 0));
    if (topic == topic_by_id_.end())
      fail(where_, "message " + std::to_string(sqlite3_column_int64(messages_, 3)) +
                       " names unknown topic id " + std::to_string(sqlite3_column_int64(messages_, 0)));
    message.topic = &topics_[topic->second];
    message.log_time_ns = sqlite3_column_int64(messages_, 1);
    const auto* blob = static_cast<const std::uint8_t*>(sqlite3_column_blob(messages_, 2));
    const int size = sqlite3_column_bytes(messages_, 2);
    message.data = std::span<const std::uint8_t>(blob, blob ? static_cast<std::size_t>(size) : 0);
    ++read_;
    return true;
  }

 private:
  sqlite3_stmt* prepare(const std::string& sql) {
    sqlite3_stmt* stmt = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &stmt, nullptr) != SQLITE_OK)
      fail(where_, "sqlite3: " + std::string(sqlite3_errmsg(db_)) + " (not a rosbag2 .db3, or a damaged one)");
    return stmt;
  }
  static std::string text(sqlite3_stmt* stmt, int column) {
    const auto* t = sqlite3_column_text(stmt, column);
    return t ? reinterpret_cast<const char*>(t) : "";
  }
  void readTopics() {
    sqlite3_stmt* stmt = prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY id");
    int rc;
    while ((rc = sqlite3_step(stmt)) == SQLITE_ROW) {
      TopicInfo t;
      t.name = text(stmt, 1);
      t.type = ros2TypeName(text(stmt, 2));
      t.serialization = serializationFromName(text(stmt, 3));
      topic_by_id_[sqlite3_column_int64(stmt, 0)] = topics_.size();
      topics_.push_back(std::move(t));
    }
    sqlite3_finalize(stmt);
    if (rc != SQLITE_DONE) fail(where_, "sqlite3: " + std::string(sqlite3_errmsg(db_)));
  }
  void readCountsAndRange() {
    // Counts and range are a convenience: a damaged file that cannot give them is still read
    // message by message as far as sqlite reaches.
    sqlite3_stmt* stmt = nullptr;
    if (sqlite3_prepare_v2(db_, "SELECT topic_id, COUNT(*), MIN(timestamp), MAX(timestamp) FROM messages GROUP BY topic_id",
                           -1, &stmt, nullptr) != SQLITE_OK) {
      loss_.notices.push_back(where_ + ": sqlite3 cannot count the messages (" + sqlite3_errmsg(db_) + ")");
      return;
    }
    bool any = false;
    int rc;
    while ((rc = sqlite3_step(stmt)) == SQLITE_ROW) {
      const auto it = topic_by_id_.find(sqlite3_column_int64(stmt, 0));
      if (it != topic_by_id_.end()) topics_[it->second].message_count = sqlite3_column_int64(stmt, 1);
      const std::int64_t lo = sqlite3_column_int64(stmt, 2), hi = sqlite3_column_int64(stmt, 3);
      range_ = any ? std::pair{std::min(range_.first, lo), std::max(range_.second, hi)} : std::pair{lo, hi};
      any = true;
    }
    if (rc != SQLITE_DONE) {
      loss_.notices.push_back(where_ + ": sqlite3 cannot count the messages (" + sqlite3_errmsg(db_) + ")");
      for (auto& t : topics_) t.message_count = 0;
      range_ = {0, 0};
    }
    sqlite3_finalize(stmt);
  }
  void prepareMessages() {
    std::string sql = "SELECT topic_id, timestamp, data, id FROM messages";
    std::vector<std::int64_t> ids;
    for (const auto& [id, index] : topic_by_id_)
      if (selected_.empty() || std::find(selected_.begin(), selected_.end(), topics_[index].name) != selected_.end())
        ids.push_back(id);
    if (!selected_.empty()) {
      sql += " WHERE topic_id IN (";
      for (std::size_t i = 0; i < ids.size(); ++i) sql += (i ? "," : "") + std::to_string(ids[i]);
      sql += ")";
    }
    messages_ = prepare(sql + " ORDER BY timestamp, id");
  }

  std::string where_;
  sqlite3* db_ = nullptr;
  sqlite3_stmt* messages_ = nullptr;
  std::vector<TopicInfo> topics_;
  std::map<std::int64_t, std::size_t> topic_by_id_;
  std::vector<std::string> selected_;
  std::pair<std::int64_t, std::int64_t> range_{0, 0};
  std::uint64_t read_ = 0;
  bool done_ = false;
};

}  // namespace

std::unique_ptr<MessageReader> openDb3(const std::filesystem::path& file) {
  return std::make_unique<Db3Reader>(file);
}

}  // namespace hazmap::sources
