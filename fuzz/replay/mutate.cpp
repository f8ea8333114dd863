#include "mutate.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <random>

namespace hazmap::fuzz {
namespace {

using Bytes = std::vector<std::uint8_t>;

// The values that break length, count and offset fields (libFuzzer's and AFL's lists agree).
constexpr std::array<std::uint32_t, 10> kInteresting = {0u, 1u, 0x7Fu, 0x80u, 0xFFu, 0x7FFFu, 0xFFFFu,
                                                        0x7FFFFFFFu, 0x80000000u, 0xFFFFFFFFu};

std::size_t below(std::mt19937_64& rng, std::size_t n) {
  return n == 0 ? 0 : std::uniform_int_distribution<std::size_t>(0, n - 1)(rng);
}

void flipBit(Bytes& b, std::mt19937_64& rng) {
  if (!b.empty()) b[below(rng, b.size())] ^= static_cast<std::uint8_t>(1u << below(rng, 8));
}

void interestingInteger(Bytes& b, std::mt19937_64& rng) {
  const std::size_t width = std::size_t{1} << below(rng, 3);  // 1, 2 or 4 bytes, little-endian
  if (b.size() < width) return;
  const std::uint32_t v = kInteresting[below(rng, kInteresting.size())];
  std::memcpy(b.data() + below(rng, b.size() - width + 1), &v, width);
}

void truncate(Bytes& b, std::mt19937_64& rng) { b.resize(below(rng, b.size() + 1)); }

void eraseRange(Bytes& b, std::mt19937_64& rng) {
  if (b.empty()) return;
  const std::size_t at = below(rng, b.size());
  const std::size_t n = 1 + below(rng, std::min<std::size_t>(b.size() - at, 64));
  b.erase(b.begin() + static_cast<std::ptrdiff_t>(at), b.begin() + static_cast<std::ptrdiff_t>(at + n));
}

void duplicateRange(Bytes& b, std::mt19937_64& rng) {
  if (b.empty()) return;
  const std::size_t at = below(rng, b.size());
  const std::size_t n = 1 + below(rng, std::min<std::size_t>(b.size() - at, 256));
  const Bytes copy(b.begin() + static_cast<std::ptrdiff_t>(at), b.begin() + static_cast<std::ptrdiff_t>(at + n));
  b.insert(b.begin() + static_cast<std::ptrdiff_t>(below(rng, b.size() + 1)), copy.begin(), copy.end());
}

void insertRandom(Bytes& b, std::mt19937_64& rng) {
  Bytes fresh(1 + below(rng, 16));
  for (auto& x : fresh) x = static_cast<std::uint8_t>(below(rng, 256));
  b.insert(b.begin() + static_cast<std::ptrdiff_t>(below(rng, b.size() + 1)), fresh.begin(), fresh.end());
}

}  // namespace

std::vector<std::uint8_t> mutate(const std::vector<std::uint8_t>& seed, std::uint64_t index) {
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a of the seed, so each seed has its own mutants
  for (const std::uint8_t x : seed) h = (h ^ x) * 1099511628211ull;
  std::mt19937_64 rng(h ^ (index * 0x9E3779B97F4A7C15ull));
  Bytes b = seed;
  const std::size_t edits = 1 + below(rng, 4);
  for (std::size_t e = 0; e < edits; ++e) {
    switch (below(rng, 8)) {
      case 0: case 1: case 2: flipBit(b, rng); break;
      case 3: case 4: interestingInteger(b, rng); break;
      case 5: truncate(b, rng); break;
      case 6: eraseRange(b, rng); duplicateRange(b, rng); break;
      default: insertRandom(b, rng); break;
    }
  }
  return b;
}

}  // namespace hazmap::fuzz
