// Force-included into every C++ translation unit of the build (root CMakeLists.txt and
// cmake/build_speed.cmake: in the precompiled header where there is one, else with --include): a
// stable sort or merge over an element type needing more than the heap's alignment does not compile.
//
// Why: libstdc++ (GCC 12) takes std::stable_sort's, std::stable_partition's and
// std::inplace_merge's scratch buffer from std::get_temporary_buffer, i.e. plain ::operator new,
// 16-byte aligned whatever alignof(T) is. Under AVX Eigen aligns Isometry3d, Matrix4d, Vector4d,
// Quaterniond, Matrix<double,6,6>... to 32 or 64 bytes and the compiler's aligned vector stores
// into that buffer fault (issue 37: hazmap odometry crashed in sortAndThin under
// -DHAZMAP_NATIVE=ON). Such ranges go through hazmap::stableSortAligned
// (include/hazmap/core/stable_sort.hpp), which sorts indices and moves each element once.
//
// The limit: in an AVX build, the real fault condition (alignof above operator new's 16). In an
// SSE-only build (the default) those Eigen types need 16 bytes, which the buffer has, so the bug
// cannot show; the guard then refuses every element type needing 16, the set that becomes 32 or
// 64 under AVX (plus 16-byte ones such as Vector2d that stay 16: refused too, harmlessly). So the
// default build, and CI with it, refuses what only a native build would crash on. Nothing here
// generates code: the specialisation is never instantiated by a build that compiles.
#pragma once
#if __has_include(<bits/stl_tempbuf.h>)
#include <bits/stl_tempbuf.h>
#include <new>

namespace hazmap_alignment_guard {
#if defined(__AVX__)
inline constexpr std::size_t kLimit = __STDCPP_DEFAULT_NEW_ALIGNMENT__;
#else
inline constexpr std::size_t kLimit = alignof(double);
#endif
}  // namespace hazmap_alignment_guard

namespace std {
template <typename _ForwardIterator, typename _Tp>
  requires(alignof(_Tp) > hazmap_alignment_guard::kLimit)
class _Temporary_buffer<_ForwardIterator, _Tp> {
  static_assert(alignof(_Tp) <= hazmap_alignment_guard::kLimit,
                "hazmap alignment check: std::stable_sort / stable_partition / inplace_merge on an "
                "over-aligned element type (fixed-size vectorisable Eigen member?): its scratch buffer "
                "comes from plain operator new; use hazmap::stableSortAligned "
                "(include/hazmap/core/stable_sort.hpp)");
};
}  // namespace std
#endif
