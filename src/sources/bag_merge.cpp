// Several message readers as one log-time stream (a rosbag2 split into files). Each child's
// data stays valid until that child's next(), so only the child whose message was handed out
// is advanced.
#include <algorithm>
#include <map>

#include "bag_readers.hpp"

namespace hazmap::sources {
namespace {

class MergedReader final : public MessageReader {
 public:
  explicit MergedReader(std::vector<std::unique_ptr<MessageReader>> readers)
      : children_(std::move(readers)), heads_(children_.size()), live_(children_.size(), false) {
    std::map<std::string, std::size_t> index;
    for (const auto& child : children_) {
      for (const auto& t : child->topics()) {
        const auto [it, fresh] = index.emplace(t.name, topics_.size());
        if (fresh) {
          topics_.push_back(t);
        } else {
          topics_[it->second].message_count += t.message_count;
        }
      }
    }
    for (const auto& child : children_) {
      std::vector<std::size_t> map;
      for (const auto& t : child->topics()) map.push_back(index.at(t.name));
      topic_maps_.push_back(std::move(map));
    }
  }

  const std::vector<TopicInfo>& topics() const override { return topics_; }
  void selectTopics(const std::vector<std::string>& names) override {
    for (auto& child : children_) child->selectTopics(names);
  }
  std::pair<std::int64_t, std::int64_t> timeRange() const override {
    std::pair<std::int64_t, std::int64_t> r{0, 0};
    bool any = false;
    for (const auto& child : children_) {
      const auto c = child->timeRange();
      if (c == std::pair<std::int64_t, std::int64_t>{0, 0}) continue;
      r = any ? std::pair{std::min(r.first, c.first), std::max(r.second, c.second)} : c;
      any = true;
    }
    return r;
  }

  bool next(BagMessage& message) override {
    if (!started_) {
      for (std::size_t i = 0; i < children_.size(); ++i) advance(i);
      started_ = true;
    } else if (last_ < children_.size()) {
      advance(last_);
    }
    std::size_t best = children_.size();
    for (std::size_t i = 0; i < children_.size(); ++i)
      if (live_[i] && (best == children_.size() || heads_[i].log_time_ns < heads_[best].log_time_ns)) best = i;
    last_ = best;
    if (best == children_.size()) return false;
    message = heads_[best];
    return true;
  }

 private:
  void advance(std::size_t i) {
    live_[i] = children_[i]->next(heads_[i]);
    if (live_[i]) {
      const auto offset = heads_[i].topic - children_[i]->topics().data();
      heads_[i].topic = &topics_[topic_maps_[i][static_cast<std::size_t>(offset)]];
    }
    gatherLoss();
  }
  void gatherLoss() {
    std::size_t notices = 0, bytes = 0, chunks = 0;
    for (const auto& child : children_) {
      notices += child->loss().notices.size();
      bytes += child->loss().bytes_unread;
      chunks += child->loss().chunks_skipped;
    }
    if (notices == loss_.notices.size() && bytes == loss_.bytes_unread && chunks == loss_.chunks_skipped) return;
    BagLoss total;
    for (const auto& child : children_) {
      total.bytes_unread += child->loss().bytes_unread;
      total.chunks_skipped += child->loss().chunks_skipped;
      total.notices.insert(total.notices.end(), child->loss().notices.begin(), child->loss().notices.end());
    }
    loss_ = std::move(total);
  }

  std::vector<std::unique_ptr<MessageReader>> children_;
  std::vector<BagMessage> heads_;
  std::vector<bool> live_;
  std::vector<TopicInfo> topics_;
  std::vector<std::vector<std::size_t>> topic_maps_;
  std::size_t last_ = 0;
  bool started_ = false;
};

}  // namespace

std::unique_ptr<MessageReader> mergeReaders(std::vector<std::unique_ptr<MessageReader>> readers) {
  return std::make_unique<MergedReader>(std::move(readers));
}

}  // namespace hazmap::sources
