#pragma once
// The splitmix64 finaliser: a cheap bijective mix of 64 bits whose every output bit depends on
// every input bit. One definition for the voxel hash tables and the simulator's random streams.
#include <cstdint>

namespace hazmap {

constexpr std::uint64_t splitmix64Mix(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

}  // namespace hazmap
