#pragma once
// The splitmix64 finaliser: a cheap bijective mix of 64 bits whose every output bit depends on
// every input bit. One definition for the map's voxel tables and the simulator's random streams.
// voxelProbeHash is the one-multiply mix for the open-addressing tables probed inside ICP's
// correspondence search and the downsampling (spatial index, voxel grouping): there the full
// finaliser made a registration measurably slower (docs/measurements.md).
#include <cstdint>

namespace hazmap {

constexpr std::uint64_t splitmix64Mix(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

/// Fibonacci hashing with a pre-shift: good enough for packed voxel keys, whose low bits change
/// fastest, and one multiply cheaper than splitmix64Mix in the hottest lookups.
constexpr std::uint64_t voxelProbeHash(std::uint64_t key) {
  key ^= key >> 29;
  key *= 0x9E3779B97F4A7C15ULL;
  return key ^ (key >> 32);
}

}  // namespace hazmap
