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
  x += kVoxelKeyBias;
  y += kVoxelKeyBias;
  z += kVoxelKeyBias;
  if (x < 0 || y < 0 || z < 0 || x > kVoxelKeyAxisMax || y > kVoxelKeyAxisMax || z > kVoxelKeyAxisMax)
    return false;
  key = (std::uint64_t(x) << 42) | (std::uint64_t(y) << 21) | std::uint64_t(z);
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

/// The voxel coordinates (x, y, z) of a key.
constexpr std::array<std::int64_t, 3> unpackVoxelKey(std::uint64_t key) {
  constexpr std::uint64_t kMask = std::uint64_t(kVoxelKeyAxisMax);
  return {std::int64_t((key >> 42) & kMask) - kVoxelKeyBias, std::int64_t((key >> 21) & kMask) - kVoxelKeyBias,
          std::int64_t(key & kMask) - kVoxelKeyBias};
}

}  // namespace hazmap
