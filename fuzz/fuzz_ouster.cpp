// libFuzzer target: Ouster metadata parser and packet decoder. The first byte picks the mode:
// 0 = the rest is metadata JSON (parsed, and a decoder built from it when small); 1 = a 16-beam
// sensor with a column window through column 0; 2..5 = an 8-beam sensor with the LEGACY,
// RNG19_RFL8_SIG16_NIR16, RNG19_RFL8_SIG16_NIR16_DUAL or RNG15_RFL8_NIR8 profile.
// In modes 1..5 the rest is cut into packets of the profile's size (the remainder is one short
// packet) and decoded.
#include <cmath>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/ouster.hpp"
#include "ouster_sensors.hpp"

namespace {

void check(const hazmap::DecodedScan& s, const hazmap::OusterMetadata& m) {
  const auto& c = s.cloud;
  if (c.classes.size() != c.size() || c.intensity.size() != c.size() || c.timestamps.size() != c.size() ||
      s.ring.size() != c.size() || s.return_type.size() != c.size())
    std::abort();
  if (c.size() > 2ull * m.columns_per_frame * m.pixels_per_column) std::abort();
  for (std::size_t i = 0; i < c.size(); ++i)
    if (!c.points[i].allFinite() || s.ring[i] >= m.pixels_per_column || !std::isfinite(c.timestamps[i]) ||
        c.points[i].norm() > 1100.0f)
      std::abort();
}

void decode(const hazmap::OusterMetadata& m, const std::uint8_t* data, std::size_t size) {
  hazmap::OusterDecoder decoder(m);
  const std::size_t n = m.lidarPacketSize();
  double t = 1000.0;
  for (std::size_t at = 0; at < size; at += n, t += 0.001) {
    decoder.addPacket({data + at, std::min(n, size - at)}, t, "fuzz");
    while (auto s = decoder.takeScan()) check(*s, m);
  }
  while (auto s = decoder.flush()) check(*s, m);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::vector<hazmap::OusterMetadata> known = hazmap::fuzz::fuzzOusterSensors();
  if (size == 0) return 0;
  const unsigned mode = data[0] % 6;
  try {
    if (mode == 0) {
      const auto m = hazmap::parseOusterMetadata(std::string(reinterpret_cast<const char*>(data + 1), size - 1), "fuzz.json");
      if (m.pixels_per_column != m.beam_altitude_deg.size() || m.columns_per_frame == 0) std::abort();
      if (std::size_t{m.columns_per_frame} * m.pixels_per_column <= 512 * 32) decode(m, nullptr, 0);
    } else {
      decode(known[mode - 1], data + 1, size - 1);
    }
  } catch (const hazmap::Error&) {
  }
  return 0;
}
