#pragma once
// The one packing of integer voxel coordinates into a 64-bit key, shared by every voxel grid (the
// downsampling, the spatial index, the local map, the global map, the map-error grid): 21 bits per
// axis, each coordinate biased by 2^20 — so [−2^20, 2^20) voxels per axis, ±105 km at 0.1 m — with
// x in the high bits, then y, then z, so that sorting keys sorts voxels x-major (the order of the
// downsampled points). Bit 63 stays clear: the hash tables use ~0 as their empty marker.
//
// Coordinates outside the range have no key (voxelKey returns false), where each grid used to
// wrap, clamp or drop in its own way: every caller now drops such a point or finds no voxel.
// Where an output must be sorted another way (the map's cells are written z-major), the caller
// sorts by voxelKey(z, y, x).
#include <array>
#include <cmath>
#include <cstdint>

namespace hazmap {

inline constexpr std::int64_t kVoxelKeyBias = std::int64_t{1} << 20;
inline constexpr std::int64_t kVoxelKeyAxisMax = (std::int64_t{1} << 21) - 1;

/// The key of voxel (x, y, z); false (key untouched) when a coordinate is out of range.
constexpr bool voxelKey(std::int64_t x, std::int64_t y, std::int64_t z, std::uint64_t& key) {
  // Biased into unsigned: a coordinate below the range wraps to a huge value, so one comparison of
  // the three or-ed together checks all six bounds (this runs ~30 times per point in the local map).
  const std::uint64_t ux = std::uint64_t(x + kVoxelKeyBias), uy = std::uint64_t(y + kVoxelKeyBias),
                      uz = std::uint64_t(z + kVoxelKeyBias);
  if ((ux | uy | uz) > std::uint64_t(kVoxelKeyAxisMax)) return false;
  key = (ux << 42) | (uy << 21) | uz;
  return true;
}

/// The voxel coordinate of `v` (already divided by the voxel size), false when it is not finite
/// or out of the key's range (checked before the integer conversion, which could overflow).
inline bool voxelCoordinate(double v, std::int64_t& c) {
  const double f = std::floor(v);
  if (!(f >= -double(kVoxelKeyBias) && f < double(kVoxelKeyBias))) return false;
  c = static_cast<std::int64_t>(f);
  return true;
}

/// floor(v) as an integer for |v| <= 2^52: truncation toward zero, one less for a negative
/// non-integer (cheaper than std::floor then a conversion: one conversion each way, no branch).
inline std::int64_t floorToInt(double v) {
  const auto t = static_cast<std::int64_t>(v);
  return t - static_cast<std::int64_t>(static_cast<double>(t) > v);
}

/// The voxel holding point (x, y, z) (coordinates already divided by the voxel size): its integer
/// coordinates and key; false when a coordinate is not finite or beyond the key's range. The same
/// answer as voxelCoordinate on each axis then voxelKey, cheaper: the downsampling and the local
/// map run it on every point of every scan.
inline bool voxelOfPoint(double x, double y, double z, std::array<std::int64_t, 3>& c, std::uint64_t& key) {
  // floor(v) is in [-2^20, 2^20) exactly when v is (the bounds are integers), so the range is
  // tested before the conversion; NaN fails every comparison; `&`, not `&&`: no branch per test.
  constexpr double lo = -double(kVoxelKeyBias), hi = double(kVoxelKeyBias);
  if (!((x >= lo) & (x < hi) & (y >= lo) & (y < hi) & (z >= lo) & (z < hi))) return false;
  c = {floorToInt(x), floorToInt(y), floorToInt(z)};
  key = (std::uint64_t(c[0] + kVoxelKeyBias) << 42) | (std::uint64_t(c[1] + kVoxelKeyBias) << 21) |
        std::uint64_t(c[2] + kVoxelKeyBias);
  return true;
}

/// The voxel coordinates (x, y, z) of a key.
constexpr std::array<std::int64_t, 3> unpackVoxelKey(std::uint64_t key) {
  constexpr std::uint64_t kMask = std::uint64_t(kVoxelKeyAxisMax);
  return {std::int64_t((key >> 42) & kMask) - kVoxelKeyBias, std::int64_t((key >> 21) & kMask) - kVoxelKeyBias,
          std::int64_t(key & kMask) - kVoxelKeyBias};
}

}  // namespace hazmap
