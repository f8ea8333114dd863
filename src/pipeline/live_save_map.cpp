#include "hazmap/pipeline/live_save_map.hpp"

#include <algorithm>
#include <iostream>
#include <string>

#include "hazmap/core/error.hpp"

namespace hazmap {

LiveSaveMap::LiveSaveMap(GlobalMapConfig map, ClassTable table, SegmentedMapConfig segments,
                         std::size_t frames_per_segment, std::size_t max_queued)
    : map_(map, std::move(table), segments), frames_per_segment_(std::max<std::size_t>(frames_per_segment, 1)),
      max_queued_(max_queued), thread_([this] { loop(); }) {}

LiveSaveMap::~LiveSaveMap() {
  {
    std::lock_guard<std::mutex> lock(m_);
    stopping_ = true;
  }
  work_.notify_all();
  done_.notify_all();
  thread_.join();
}

void LiveSaveMap::frame(const SlamFrameEvent& event, std::span<const PointChannel> channels) {
  {
    std::lock_guard<std::mutex> lock(m_);
    if (given_up_) return;
    // The thread that far behind, or a frame without its pose: tracking goes first.
    if (queued_frames_ >= max_queued_ || event.record.index >= event.poses.size()) {
      giveUp();
      return;
    }
  }
  if (!open_ || in_segment_ >= frames_per_segment_) {  // as the thread's SegmentedMap::add will see it
    open_ = true;
    anchor_ = event.record.index;
    in_segment_ = 0;
  }
  ++in_segment_;
  Item item;
  item.frame = event.record.index;
  item.cloud = event.scan;
  item.channels.assign(channels.begin(), channels.end());
  item.pose = event.poses[event.record.index];
  item.anchor = anchor_;
  item.anchor_pose = event.poses[anchor_];
  push(std::move(item));
}

void LiveSaveMap::cut(std::size_t frames) {
  open_ = false;
  Item item;
  item.is_cut = true;
  item.frame = frames;
  push(std::move(item));
}

void LiveSaveMap::push(Item item) {
  {
    std::lock_guard<std::mutex> lock(m_);
    if (given_up_) return;
    if (!item.is_cut) ++queued_frames_;
    queue_.push_back(std::move(item));
  }
  work_.notify_one();
}

void LiveSaveMap::giveUp() {
  given_up_ = true;
  queue_.clear();
  queued_frames_ = 0;
  done_.notify_all();
}

bool LiveSaveMap::complete() const {
  std::lock_guard<std::mutex> lock(m_);
  return !given_up_;
}

std::optional<GlobalMap> LiveSaveMap::compose(std::size_t frames, std::span<const Eigen::Isometry3d> poses) {
  {
    std::unique_lock<std::mutex> lock(m_);
    done_.wait(lock, [&] { return given_up_ || stopping_ || cut_at_ >= frames; });
    if (given_up_ || cut_at_ < frames) return std::nullopt;
  }
  try {
    return map_.compose(frames, poses);
  } catch (const Error&) {  // no cut at `frames` (a snapshot taken without one)
    return std::nullopt;
  }
}

void LiveSaveMap::loop() {
  std::unique_lock<std::mutex> lock(m_);
  while (true) {
    work_.wait(lock, [&] { return !queue_.empty() || stopping_; });
    if (stopping_) return;
    Item item = std::move(queue_.front());
    queue_.pop_front();
    if (!item.is_cut) --queued_frames_;
    lock.unlock();
    bool failed = false;
    try {
      if (item.is_cut) {
        if (map_.frames() != item.frame)
          fail("live save map", "a cut at frame " + std::to_string(item.frame) + " after " + std::to_string(map_.frames()));
        map_.close();
      } else {
        map_.add(item.frame, item.cloud, item.channels, item.pose, item.anchor, item.anchor_pose);
      }
    } catch (const std::exception& e) {  // a frame out of order, a bad pose: the saves rebuild
      std::cerr << "notice: the saves' map gave up (" << e.what() << "); saves rebuild it from the spool\n";
      failed = true;
    }
    lock.lock();
    if (failed) giveUp();
    else if (item.is_cut) cut_at_ = std::max(cut_at_, item.frame);
    done_.notify_all();
  }
}

}  // namespace hazmap
