#include "block_merge.hpp"

#include <algorithm>

#include "hazmap/core/error.hpp"

namespace hazmap::sources {

void checkEntryTimes(const MergeBlock& block, const std::vector<MergeEntry>& entries, const std::string& where) {
  for (const auto& e : entries)
    if (e.time < block.start_time)
      fail(where, "message at " + std::to_string(e.time) + " ns precedes the chunk's declared start " +
                      std::to_string(block.start_time) + " ns (corrupt chunk header or index)");
}

BlockMerger::BlockMerger(std::vector<MergeBlock> blocks, Loader loader)
    : blocks_(std::move(blocks)), loader_(std::move(loader)) {
  std::stable_sort(blocks_.begin(), blocks_.end(), [](const MergeBlock& a, const MergeBlock& b) {
    return a.start_time != b.start_time ? a.start_time < b.start_time : a.offset < b.offset;
  });
}

void BlockMerger::release(std::uint32_t slot) {
  if (--slots_[slot].pending == 0) free_slots_.push_back(slot);
}

void BlockMerger::load(const MergeBlock& block) {
  std::uint32_t slot;
  if (!free_slots_.empty()) {
    slot = free_slots_.back();
    free_slots_.pop_back();
  } else {
    slot = static_cast<std::uint32_t>(slots_.size());
    slots_.emplace_back();
  }
  scratch_.clear();
  try {
    loader_(block, slots_[slot].buffer, scratch_);
  } catch (...) {
    free_slots_.push_back(slot);
    throw;
  }
  if (scratch_.empty()) {
    free_slots_.push_back(slot);
    return;
  }

  slots_[slot].pending = scratch_.size();
  for (const auto& e : scratch_) heap_.push({e.time, sequence_++, slot, e.topic, e.data});
}

bool BlockMerger::next(MergeEntry& out) {
  if (held_slot_ >= 0) {
    release(static_cast<std::uint32_t>(held_slot_));
    held_slot_ = -1;
  }
  while (next_block_ < blocks_.size() && (heap_.empty() || blocks_[next_block_].start_time <= heap_.top().time))
    load(blocks_[next_block_++]);
  if (heap_.empty()) return false;
  const Pending top = heap_.top();
  heap_.pop();
  held_slot_ = top.slot;
  out = {top.time, top.topic, top.data};
  return true;
}

}  // namespace hazmap::sources
