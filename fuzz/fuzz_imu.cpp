// libFuzzer target: IMU streams. The first byte picks the input: 'R' = the rest is an
// --imu-rotation text (a rotation or hazmap::Error); other even bytes = the rest is an imu.txt
// (read, cleaned, cut into spans); odd = the rest is cut into 48-byte Ouster IMU packets, decoded
// alone and through the OS-1-128-like decoder beside its lidar packets.
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "fuzz_input.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/imu.hpp"
#include "hazmap/sources/imu_rotation.hpp"
#include "hazmap/sources/ouster.hpp"
#include "ouster_sensors.hpp"

namespace {

void checkStream(std::vector<hazmap::ImuSample> samples) {
  for (const auto& s : samples)
    if (!std::isfinite(s.time) || !s.gyro.allFinite() || !s.accel.allFinite()) std::abort();
  hazmap::cleanImuStream(samples, hazmap::kImuMaxGap);
  for (std::size_t i = 1; i < samples.size(); ++i)
    if (!(samples[i].time > samples[i - 1].time)) std::abort();
  if (samples.empty()) return;
  const double t0 = samples.front().time, t1 = samples.back().time;
  for (double f : {0.0, 0.25, 0.5}) {
    const auto span = hazmap::imuSpan(samples, t0 + f * (t1 - t0), t0 + (f + 0.3) * (t1 - t0));
    if (!span.empty() && (span.front().time > t0 + f * (t1 - t0) || span.size() > samples.size())) std::abort();
  }
}

void decodePackets(const std::uint8_t* data, std::size_t size) {
  static const std::vector<hazmap::OusterMetadata> known = hazmap::fuzz::fuzzOusterSensors();
  hazmap::OusterDecoder decoder(known.front());
  double t = 1000.0;
  for (std::size_t at = 0; at + hazmap::kOusterImuPacketSize <= size; at += hazmap::kOusterImuPacketSize, t += 0.01) {
    const std::span<const std::uint8_t> packet(data + at, hazmap::kOusterImuPacketSize);
    if (const auto d = hazmap::decodeOusterImuPacket(packet, known.front()))
      if (!d->sample.gyro.allFinite() || !d->sample.accel.allFinite()) std::abort();
    decoder.addPacket(packet, t, "fuzz");
  }
  checkStream(decoder.takeImu());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static hazmap::fuzz::MemFile file("imu.txt");
  if (size == 0) return 0;
  if (data[0] % 2 == 1) {
    decodePackets(data + 1, size - 1);
    return 0;
  }
  if (data[0] == 'R') {
    try {
      const Eigen::Matrix3d R = hazmap::parseImuRotation(std::string(data + 1, data + size), "--imu-rotation");
      if (!R.allFinite() || (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 || R.determinant() < 0.99)
        std::abort();
    } catch (const hazmap::Error&) {
    }
    return 0;
  }
  try {
    checkStream(hazmap::readImuFile(file.set(data + 1, size - 1)));
  } catch (const hazmap::Error&) {
  }
  return 0;
}
