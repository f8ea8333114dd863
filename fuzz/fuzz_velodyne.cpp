// libFuzzer target: Velodyne packet decoder (packets of the right sizes — data and position —
// and of wrong ones, any factory bytes, forced or detected model, any cut angle and field of
// view) and the calibration YAML reader.
// Input: byte 0 flags (bit 7: the rest is a calibration YAML; bits 0–2: forced model; bit 3:
// field of view up to 90°; bit 4: exact azimuths), byte 1
// cut angle (× 1.5°), byte 2 field of view start (× 1.5°); then records of one selector byte
// (0 mod 3: a 1206-byte data packet, 1: a 512-byte position packet, else that many bytes)
// followed by the payload (zero-padded at the end of the input).
#include <algorithm>
#include <vector>

#include "fuzz_input.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/sources/velodyne.hpp"

namespace {

void checkScan(const hazmap::DecodedScan& s) {
  hazmap::fuzz::checkCloud(s.cloud);
  if (s.ring.size() != s.cloud.size() || s.return_type.size() != s.cloud.size()) std::abort();
  if (s.cloud.intensity.size() != s.cloud.size() || s.cloud.timestamps.size() != s.cloud.size())
    std::abort();
  for (std::size_t i = 0; i < s.cloud.size(); ++i) {
    if (s.ring[i] >= 128 || s.return_type[i] < 1 || s.return_type[i] > 6) std::abort();
    if (!(s.cloud.intensity[i] >= 0 && s.cloud.intensity[i] <= 255)) std::abort();
    if (s.cloud.points[i].norm() > 300.0f) std::abort();  // the default max range
  }
  if (!s.cloud.empty() && s.stamp != s.cloud.timestamps.front()) std::abort();
}

void fuzzCalibration(const std::uint8_t* data, std::size_t size) {
  static hazmap::fuzz::MemFile file("fuzz_velodyne.yaml");
  const std::string& path = file.set(data, size);
  try {
    const auto c = hazmap::loadVelodyneCalibration(path, hazmap::VelodyneModel::VLP16);
    if (c.lasers.size() != 16) std::abort();
  } catch (const hazmap::Error&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 3) return 0;
  if (data[0] & 0x80) {
    fuzzCalibration(data + 1, size - 1);
    return 0;
  }
  hazmap::VelodyneOptions options;
  const int forced = data[0] & 0x07;
  if (forced >= 1 && forced <= 4) options.model = static_cast<hazmap::VelodyneModel>(forced - 1);
  options.cut_angle = std::min(360.0, data[1] * 1.5);
  options.fov_min = std::min(360.0, data[2] * 1.5);
  options.fov_max = data[0] & 0x08 ? 90.0 : 360.0;
  options.exact_azimuth = data[0] & 0x10;
  auto decoder = hazmap::makeVelodyneDecoder(options);
  std::vector<std::uint8_t> payload;
  double time = 1000.0;
  for (std::size_t at = 3; at < size;) {
    const std::uint8_t selector = data[at++];
    const std::size_t n = selector % 3 == 0 ? hazmap::kVelodyneDataPacketSize
                          : selector % 3 == 1 ? hazmap::kVelodynePositionPacketSize
                                              : selector;
    payload.assign(n, 0);
    const std::size_t take = std::min(n, size - at);
    std::copy(data + at, data + at + take, payload.begin());
    at += take;
    time += 0.0013;
    try {
      decoder->addPacket(payload, time, "fuzz");
    } catch (const hazmap::Error&) {
    }
    while (auto s = decoder->takeScan()) checkScan(*s);
  }
  try {
    if (auto s = decoder->flush()) checkScan(*s);
  } catch (const hazmap::Error&) {
  }
  decoder->describe();
  return 0;
}
