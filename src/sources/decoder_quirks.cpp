// DecoderQuirks: counts of what the packet decoders tolerated, each kind warned once.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "hazmap/sources/packet_decoder.hpp"

namespace hazmap {

void DecoderQuirks::note(const std::string& kind, const std::string& where, std::uint64_t n) {
  for (auto& [k, c] : counts)
    if (k == kind) {
      c += n;
      return;
    }
  counts.emplace_back(kind, n);
  spdlog::warn("{}: {} (tolerated; further ones are counted, not warned)", where, kind);
}

std::uint64_t DecoderQuirks::count(const std::string& kind) const {
  for (const auto& [k, c] : counts)
    if (k == kind) return c;
  return 0;
}

std::uint64_t DecoderQuirks::total() const {
  std::uint64_t n = 0;
  for (const auto& kc : counts) n += kc.second;
  return n;
}

std::string DecoderQuirks::summary() const {
  std::string out;
  for (const auto& [k, c] : counts) out += fmt::format("{}{} × {}", out.empty() ? "" : ", ", c, k);
  return out;
}

}  // namespace hazmap
