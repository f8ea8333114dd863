#pragma once
// Deterministic byte mutations for the fuzz replay (replay_main.cpp): what a coverage-guided
// fuzzer tries first on a seed — bit flips, "interesting" integers over length and count fields,
// truncation, erased, duplicated and inserted ranges — without its instrumentation, so the
// targets run in the normal build. The same seed and index always give the same mutant.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace hazmap::fuzz {

/// Mutant number `index` of `seed` (1 to 4 stacked edits, chosen by a PRNG seeded by both).
std::vector<std::uint8_t> mutate(const std::vector<std::uint8_t>& seed, std::uint64_t index);

}  // namespace hazmap::fuzz
