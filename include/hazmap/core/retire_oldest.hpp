#pragma once
// A list that keeps only its newest entries in full: the oldest beyond `keep` are handed to
// `retire` (which keeps what is still needed of them, elsewhere), oldest first, then dropped.
// Returns how many went. The tracker's frames, its records and the back end's journal (issue 33).
#include <algorithm>
#include <cstddef>
#include <vector>

namespace hazmap {

template <class T, class Retire>
std::size_t retireOldest(std::vector<T>& newest, std::size_t keep, Retire retire) {
  if (newest.size() <= keep) return 0;
  const auto drop = static_cast<std::ptrdiff_t>(newest.size() - keep);
  std::for_each(newest.begin(), newest.begin() + drop, retire);
  newest.erase(newest.begin(), newest.begin() + drop);
  return static_cast<std::size_t>(drop);
}

}  // namespace hazmap
