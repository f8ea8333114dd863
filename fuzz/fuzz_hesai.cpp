// libFuzzer target: Hesai packet decoder (packets of each model's size and of any other, any
// header, return mode and azimuths, forced or detected model, any cut angle and field of view)
// and the angle-correction CSV reader.
// Input: byte 0 flags (bit 7: the rest is an angle-correction CSV for the model of bits 0–2;
// bits 0–2: forced model 1–7, else detected; bit 3: field of view 270°–90°), byte 1 cut angle
// (× 1.4°); then records of one selector byte (0–6 mod 8: a packet of that model's size, else
// that many bytes / 2) followed by the payload (zero-padded at the end of the input).
#include <algorithm>
#include <vector>

#include "fuzz_input.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/sources/hesai.hpp"

namespace {

// Each model's data packet size with its optional trailers, as the sensors send them.
constexpr std::size_t kSizes[7] = {1262, 1198, 1072, 1127, 568, 1080, 820};

void checkScan(const hazmap::DecodedScan& s) {
  hazmap::fuzz::checkCloud(s.cloud);
  if (s.ring.size() != s.cloud.size() || s.return_type.size() != s.cloud.size()) std::abort();
  if (s.cloud.intensity.size() != s.cloud.size() || s.cloud.timestamps.size() != s.cloud.size()) std::abort();
  for (std::size_t i = 0; i < s.cloud.size(); ++i) {
    if (s.ring[i] >= 128 || s.return_type[i] > 3) std::abort();
    if (!(s.cloud.intensity[i] >= 0 && s.cloud.intensity[i] <= 255)) std::abort();
    if (s.cloud.points[i].norm() > 300.01f) std::abort();  // the widest model range
  }
  if (!s.cloud.empty() && s.stamp != s.cloud.timestamps.front()) std::abort();
}

void fuzzCalibration(hazmap::HesaiModel model, const std::uint8_t* data, std::size_t size) {
  static hazmap::fuzz::MemFile file("fuzz_hesai.csv");
  const std::string& path = file.set(data, size);
  try {
    const auto c = hazmap::loadHesaiCalibration(path, model);
    const auto n = static_cast<std::size_t>(hazmap::hesaiChannelCount(model));
    if (c.elevation_deg.size() != n || c.azimuth_deg.size() != n) std::abort();
    for (std::size_t i = 0; i < n; ++i)
      if (!(std::abs(c.elevation_deg[i]) <= 90 && std::abs(c.azimuth_deg[i]) <= 180)) std::abort();
  } catch (const hazmap::Error&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  const int forced = data[0] & 0x07;
  if (data[0] & 0x80) {
    fuzzCalibration(static_cast<hazmap::HesaiModel>(forced % 7), data + 1, size - 1);
    return 0;
  }
  hazmap::HesaiOptions options;
  if (forced >= 1) options.model = static_cast<hazmap::HesaiModel>(forced - 1);
  options.cut_angle = std::min(359.0, data[1] * 1.4);
  if (data[0] & 0x08) options.fov_min = 270, options.fov_max = 90;
  auto decoder = hazmap::makeHesaiDecoder(options);
  std::vector<std::uint8_t> payload;
  double time = 1000.0;
  for (std::size_t at = 2; at < size;) {
    const std::uint8_t selector = data[at++];
    const std::size_t n = selector % 8 < 7 ? kSizes[selector % 8] : selector / 2;
    payload.assign(n, 0);
    const std::size_t take = std::min(n, size - at);
    std::copy(data + at, data + at + take, payload.begin());
    at += take;
    time += 0.0002;
    decoder->addPacket(payload, time, "fuzz");  // tolerant: never throws on packet content
    while (auto s = decoder->takeScan()) checkScan(*s);
  }
  while (auto s = decoder->flush()) checkScan(*s);
  decoder->describe();
  return 0;
}
