#pragma once
// A stable sort for element types that may be over-aligned (issue 37, part 4).
//
// libstdc++'s std::stable_sort (and stable_partition, inplace_merge) takes its scratch buffer
// from plain ::operator new, which is 16-byte aligned whatever alignof(T) asks. Under
// -march=native Eigen aligns fixed-size vectorisable members (Isometry3d, Matrix4d, Vector4d,
// Quaterniond, Matrix<double, 6, 6>...) to 32 or 64 bytes, and the compiler's aligned AVX stores
// into that buffer fault. This sorts indices instead (std::stable_sort over std::size_t, with the
// same comparator, ties by position) and then moves each element once into storage from
// std::allocator (aligned new): the same order, and the same values, as std::stable_sort on the
// elements, in every build. scripts/check-alignment.sh finds any stable sort that needs it.
#include <algorithm>
#include <cstddef>
#include <numeric>
#include <utility>
#include <vector>

namespace hazmap {

template <typename T, typename Allocator, typename Less>
void stableSortAligned(std::vector<T, Allocator>& v, Less less) {
  std::vector<std::size_t> order(v.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return less(v[a], v[b]); });
  std::vector<T, Allocator> sorted(v.get_allocator());
  sorted.reserve(v.size());
  for (const std::size_t i : order) sorted.push_back(std::move(v[i]));
  v = std::move(sorted);
}

}  // namespace hazmap
