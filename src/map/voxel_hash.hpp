#pragma once
// Private: an open-addressing hash map from packed voxel keys to cell values, for the map and
// the map-error grids. Linear probing on a power-of-two table of (key, index) slots; values
// live densely in a deque (stable, no reallocation spikes), so iteration is a linear walk.
// No node allocation per cell, unlike std::unordered_map (measured: docs/measurements.md).
#include <cstddef>
#include <cstdint>
#include <deque>
#include <utility>
#include <vector>

#include "hazmap/core/hash.hpp"

namespace hazmap::detail {

template <class Value>
class VoxelHashMap {
 public:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t(0);  // packed keys never use bit 63

  std::size_t size() const { return values_.size(); }
  bool empty() const { return values_.empty(); }

  Value& operator[](std::uint64_t key) {
    if ((values_.size() + 1) * 10 > slots_.size() * 7) grow();
    std::size_t i = hash(key) & mask_;
    while (true) {
      Slot& s = slots_[i];
      if (s.key == key) return values_[s.index];
      if (s.key == kEmpty) {
        s.key = key;
        s.index = static_cast<std::uint32_t>(values_.size());
        keys_.push_back(key);
        values_.emplace_back();
        return values_.back();
      }
      i = (i + 1) & mask_;
    }
  }

  const Value* find(std::uint64_t key) const {
    if (slots_.empty()) return nullptr;
    std::size_t i = hash(key) & mask_;
    while (true) {
      const Slot& s = slots_[i];
      if (s.key == key) return &values_[s.index];
      if (s.key == kEmpty) return nullptr;
      i = (i + 1) & mask_;
    }
  }

  /// Entry i (insertion order).
  std::uint64_t keyAt(std::size_t i) const { return keys_[i]; }
  const Value& valueAt(std::size_t i) const { return values_[i]; }
  Value& valueAt(std::size_t i) { return values_[i]; }

  void clear() {
    slots_.clear();
    slots_.shrink_to_fit();
    keys_.clear();
    values_.clear();
    mask_ = 0;
  }
  void swap(VoxelHashMap& other) noexcept {
    slots_.swap(other.slots_);
    keys_.swap(other.keys_);
    values_.swap(other.values_);
    std::swap(mask_, other.mask_);
  }
  /// Removes and returns the last entry's key and value (used to drain a map while building
  /// another one, so the two never hold everything at once).
  std::pair<std::uint64_t, Value> popBackUnindexed() {
    std::pair<std::uint64_t, Value> kv{keys_.back(), std::move(values_.back())};
    keys_.pop_back();
    values_.pop_back();
    return kv;
  }
  /// Drops the probing table (after popBackUnindexed() drained entries it is stale).
  void dropIndex() {
    slots_.clear();
    slots_.shrink_to_fit();
    mask_ = 0;
  }

  std::size_t memoryBytes() const {
    return slots_.capacity() * sizeof(Slot) + keys_.size() * sizeof(std::uint64_t) +
           values_.size() * sizeof(Value);
  }

 private:
  struct Slot {
    std::uint64_t key = kEmpty;
    std::uint32_t index = 0;
  };
  static std::size_t hash(std::uint64_t x) { return static_cast<std::size_t>(splitmix64Mix(x)); }
  void grow() {
    const std::size_t n = slots_.empty() ? 1024 : slots_.size() * 2;
    std::vector<Slot> fresh(n);
    mask_ = n - 1;
    for (std::size_t v = 0; v < keys_.size(); ++v) {
      std::size_t i = hash(keys_[v]) & mask_;
      while (fresh[i].key != kEmpty) i = (i + 1) & mask_;
      fresh[i].key = keys_[v];
      fresh[i].index = static_cast<std::uint32_t>(v);
    }
    slots_.swap(fresh);
  }

  std::vector<Slot> slots_;
  std::deque<std::uint64_t> keys_;
  std::deque<Value> values_;
  std::size_t mask_ = 0;
};

}  // namespace hazmap::detail
