#pragma once
// Internal (not API): the local map's voxel key → slot lookup. Open addressing with linear probing on a
// power-of-two table kept at most half full, and backward-shift deletion (no tombstones, so a
// map that drops and adds voxels every frame never degrades). A lookup is one or two probes in
// one cache line, where std::unordered_map chases a bucket pointer and a node: the map's normal
// search and its staleness checks make ~30 lookups per point (docs/measurements.md).
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "hazmap/core/hash.hpp"

namespace hazmap::detail {

class VoxelKeyIndex {
 public:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // packed keys never use bit 63

  std::size_t size() const { return size_; }

  /// The value of `key`, or nullptr.
  const std::uint32_t* find(std::uint64_t key) const {
    if (size_ == 0) return nullptr;
    for (std::size_t i = home(key);; i = (i + 1) & mask_) {
      const Slot& s = slots_[i];
      if (s.key == key) return &s.value;
      if (s.key == kEmpty) return nullptr;
    }
  }
  std::uint32_t* find(std::uint64_t key) {
    return const_cast<std::uint32_t*>(static_cast<const VoxelKeyIndex*>(this)->find(key));
  }

  /// Inserts key → value unless the key is present; returns its value and whether it was added.
  std::pair<std::uint32_t*, bool> tryEmplace(std::uint64_t key, std::uint32_t value) {
    if (2 * (size_ + 1) > slots_.size()) rehash(slots_.empty() ? 1024 : 2 * slots_.size());
    std::size_t i = home(key);
    while (slots_[i].key != kEmpty && slots_[i].key != key) i = (i + 1) & mask_;
    if (slots_[i].key == key) return {&slots_[i].value, false};
    slots_[i] = {key, value};
    ++size_;
    return {&slots_[i].value, true};
  }

  void erase(std::uint64_t key) {
    if (size_ == 0) return;
    std::size_t i = home(key);
    while (slots_[i].key != key) {
      if (slots_[i].key == kEmpty) return;
      i = (i + 1) & mask_;
    }
    // Backward shift: pull later entries of the probe run into the hole unless their home lies
    // cyclically in (hole, j] (then they are already reachable).
    for (std::size_t j = (i + 1) & mask_; slots_[j].key != kEmpty; j = (j + 1) & mask_) {
      const std::size_t h = home(slots_[j].key);
      const bool reachable = i <= j ? (i < h && h <= j) : (i < h || h <= j);
      if (reachable) continue;
      slots_[i] = slots_[j];
      i = j;
    }
    slots_[i].key = kEmpty;
    --size_;
  }

  void clear() {
    slots_.clear();
    mask_ = 0;
    size_ = 0;
  }

 private:
  struct Slot {
    std::uint64_t key = kEmpty;
    std::uint32_t value = 0;
  };
  std::size_t home(std::uint64_t key) const { return static_cast<std::size_t>(splitmix64Mix(key)) & mask_; }
  void rehash(std::size_t n) {
    std::vector<Slot> old(n);
    old.swap(slots_);
    mask_ = n - 1;
    size_ = 0;
    for (const Slot& s : old)
      if (s.key != kEmpty) tryEmplace(s.key, s.value);
  }

  std::vector<Slot> slots_;
  std::size_t mask_ = 0;
  std::size_t size_ = 0;
};

}  // namespace hazmap::detail
