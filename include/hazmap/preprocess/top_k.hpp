#pragma once
// The k smallest candidates of a neighbour search, kept sorted in a caller-owned buffer. An
// insertion shifts the few larger entries in place: a k-NN for a normal (k ≈ 10) sees a hundred
// or more candidates, and a vector insert/pop per candidate was a visible share of the search
// (docs/measurements.md).
#include <algorithm>
#include <cstddef>
#include <vector>

namespace hazmap {

/// `Entry` has a float `distance2`. Ties keep arrival order (a later equal candidate ranks
/// after the earlier ones and does not displace the k-th).
template <class Entry>
class TopK {
 public:
  /// Uses `buffer` (resized to k; its contents are replaced) for at most k entries closer than
  /// max_distance2.
  TopK(std::vector<Entry>& buffer, std::size_t k, float max_distance2)
      : best_(buffer), k_(k), bound_(max_distance2), max_(max_distance2) {
    best_.resize(k_);
  }
  /// Only candidates with distance2 < bound() can enter: max_distance2 until k are held, then the
  /// k-th distance.
  float bound() const { return bound_; }
  void push(const Entry& e) {
    if (!(e.distance2 < bound_) || k_ == 0) return;
    std::size_t at = count_ < k_ ? count_ : k_ - 1;
    while (at > 0 && best_[at - 1].distance2 > e.distance2) {
      best_[at] = best_[at - 1];
      --at;
    }
    best_[at] = e;
    if (count_ < k_) ++count_;
    if (count_ == k_) bound_ = std::min(best_[k_ - 1].distance2, max_);
  }
  std::size_t size() const { return count_; }
  /// Shrinks the buffer to the entries found (sorted by distance).
  void finish() { best_.resize(count_); }

 private:
  std::vector<Entry>& best_;
  std::size_t k_, count_ = 0;
  float bound_, max_;
};

}  // namespace hazmap
