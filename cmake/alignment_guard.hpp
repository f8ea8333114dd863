// Force-included (-include) by scripts/check-alignment.sh into a compile-only pass over the
// translation units that use std::stable_sort, std::stable_partition or std::inplace_merge, built
// as for AVX-512 (-march=x86-64-v4: Eigen then aligns fixed-size vectorisable types to 32 or 64
// bytes). Never part of a real build.
//
// Why: libstdc++ (GCC 12) takes those algorithms' scratch buffer from std::get_temporary_buffer,
// i.e. plain ::operator new, 16-byte aligned whatever alignof(T) is. An element type holding an
// Eigen::Isometry3d, Matrix4d, Vector4d, Quaterniond or 6x6 matrix is over-aligned under AVX, and
// the compiler's aligned vector stores into that buffer fault (issue 37: hazmap odometry crashed
// in sortAndThin under -DHAZMAP_NATIVE=ON). Such ranges go through hazmap::stableSortAligned
// (include/hazmap/core/stable_sort.hpp), which sorts indices and moves the elements once.
#pragma once
#include <bits/stl_tempbuf.h>
#include <new>

namespace std {
template <typename _ForwardIterator, typename _Tp>
  requires(alignof(_Tp) > __STDCPP_DEFAULT_NEW_ALIGNMENT__)
class _Temporary_buffer<_ForwardIterator, _Tp> {
  static_assert(alignof(_Tp) <= __STDCPP_DEFAULT_NEW_ALIGNMENT__,
                "hazmap alignment check: std::stable_sort / stable_partition / inplace_merge on an "
                "over-aligned element type (fixed-size vectorisable Eigen member?): its scratch buffer "
                "comes from plain operator new; use hazmap::stableSortAligned "
                "(include/hazmap/core/stable_sort.hpp)");
};
}  // namespace std
