#pragma once
// What the MCAP and ROS 1 readers share: both index a file as blocks of messages (chunks or
// single records), merge them into log-time order with BlockMerger, filter by topic, and report
// corrupt chunks once each. A reader supplies its topics, blocks and time range, and loadBlock().
#include <algorithm>
#include <cstdint>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "block_merge.hpp"
#include "hazmap/sources/bag_message.hpp"

namespace hazmap::sources {

class ChunkedBagReader : public MessageReader {
 public:
  const std::vector<TopicInfo>& topics() const final { return topics_; }
  std::pair<std::int64_t, std::int64_t> timeRange() const final { return range_; }
  void selectTopics(const std::vector<std::string>& names) final {
    for (std::size_t i = 0; i < topics_.size(); ++i)
      selected_[i] = names.empty() || std::find(names.begin(), names.end(), topics_[i].name) != names.end();
  }
  bool next(BagMessage& message) final {
    if (!started_) {
      merger_ = BlockMerger(std::move(blocks_), [this](const MergeBlock& b, std::vector<std::uint8_t>& buf,
                                                       std::vector<MergeEntry>& out) { loadBlock(b, buf, out); });
      started_ = true;
    }
    MergeEntry e;
    if (!merger_.next(e)) return false;
    message.topic = &topics_[e.topic];
    message.log_time_ns = e.time;
    message.data = e.data;
    return true;
  }

 protected:
  explicit ChunkedBagReader(std::string where) : where_(std::move(where)) {}

  /// The block's selected messages (BlockMerger::Loader's contract).
  virtual void loadBlock(const MergeBlock& b, std::vector<std::uint8_t>& buffer, std::vector<MergeEntry>& out) = 0;

  void extendRange(std::int64_t t) {
    range_ = any_time_ ? std::pair{std::min(range_.first, t), std::max(range_.second, t)} : std::pair{t, t};
    any_time_ = true;
  }
  /// Records a corrupt chunk once (its offset and why) and counts it as skipped.
  void skipChunk(std::uint64_t offset, const std::string& why) {
    if (!bad_chunks_.insert(offset).second) return;
    ++loss_.chunks_skipped;
    loss_.notices.push_back(where_ + ": chunk at offset " + std::to_string(offset) + " skipped: " + why);
  }

  std::string where_;
  std::vector<TopicInfo> topics_;
  std::vector<char> selected_;  ///< per topic
  std::vector<MergeBlock> blocks_;
  std::set<std::uint64_t> bad_chunks_;
  std::pair<std::int64_t, std::int64_t> range_{0, 0};
  bool any_time_ = false;

 private:
  BlockMerger merger_;
  bool started_ = false;
};

}  // namespace hazmap::sources
