#pragma once
// Log-time order over blocks of messages (MCAP chunks, ROS 1 chunks, single records), loading
// each block only when its start time is reached, so memory holds just the blocks whose time
// ranges overlap — not the file. Ties keep load order, i.e. file order.
#include <cstdint>
#include <functional>
#include <queue>
#include <span>
#include <string>
#include <vector>

namespace hazmap::sources {

struct MergeBlock {
  std::int64_t start_time = 0;  ///< earliest message in the block (ns)
  std::uint64_t offset = 0;     ///< file offset: the tie-break and the loader's key
  std::uint32_t tag = 0;        ///< loader-defined (e.g. a record kind)
};

struct MergeEntry {
  std::int64_t time = 0;
  std::uint32_t topic = 0;  ///< index into the reader's topics
  std::span<const std::uint8_t> data;
};

/// Throws hazmap::Error when a message is earlier than its block's declared start (a corrupt
/// chunk header or index): such a block cannot be merged in order.
void checkEntryTimes(const MergeBlock& block, const std::vector<MergeEntry>& entries, const std::string& where);

class BlockMerger {
 public:
  /// Fills `entries` with the block's messages (none when the block is skipped); `buffer` is
  /// the block's own storage to point into (it keeps its capacity between uses). No entry may
  /// be earlier than the block's start_time (checkEntryTimes), or the order would break.
  using Loader = std::function<void(const MergeBlock&, std::vector<std::uint8_t>& buffer,
                                    std::vector<MergeEntry>& entries)>;

  BlockMerger() = default;
  BlockMerger(std::vector<MergeBlock> blocks, Loader loader);
  /// The next message in time order; false at the end. Its data stays valid until the next call.
  bool next(MergeEntry& out);

 private:
  struct Pending {
    std::int64_t time;
    std::uint64_t sequence;
    std::uint32_t slot;
    std::uint32_t topic;
    std::span<const std::uint8_t> data;
    bool operator>(const Pending& o) const {
      return time != o.time ? time > o.time : sequence > o.sequence;
    }
  };
  struct Slot {
    std::vector<std::uint8_t> buffer;
    std::size_t pending = 0;
  };
  void load(const MergeBlock& block);
  void release(std::uint32_t slot);

  std::vector<MergeBlock> blocks_;
  Loader loader_;
  std::size_t next_block_ = 0;
  std::priority_queue<Pending, std::vector<Pending>, std::greater<>> heap_;
  std::vector<Slot> slots_;
  std::vector<std::uint32_t> free_slots_;
  std::vector<MergeEntry> scratch_;
  std::uint64_t sequence_ = 0;
  std::int64_t held_slot_ = -1;
};

}  // namespace hazmap::sources
