// Ouster IMU packets (include/hazmap/sources/ouster.hpp): the LEGACY 48-byte layout of the
// firmware user manual ("IMU Data Format"): u64 system time, u64 accelerometer time, u64 gyro
// time (ns), then accelerometer x y z (float32, g) and gyro x y z (float32, °/s), IMU frame.
#include <cmath>
#include <cstring>

#include "hazmap/sources/ouster.hpp"

namespace hazmap {

namespace {

constexpr double kStandardGravity = 9.80665;  // m/s² per g (the sensor reports g)

template <typename T>
T loadLe(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

}  // namespace

std::optional<OusterImuPacket> decodeOusterImuPacket(std::span<const std::uint8_t> payload,
                                                     const OusterMetadata& metadata) {
  if (payload.size() != kOusterImuPacketSize) return std::nullopt;
  const std::uint8_t* p = payload.data();
  OusterImuPacket out;
  out.gyro_time_ns = loadLe<std::uint64_t>(p + 16);
  Eigen::Vector3d accel, gyro;
  for (int k = 0; k < 3; ++k) {
    accel[k] = loadLe<float>(p + 24 + 4 * k);
    gyro[k] = loadLe<float>(p + 36 + 4 * k);
  }
  if (!accel.allFinite() || !gyro.allFinite()) return std::nullopt;
  const Eigen::Matrix3d R_sensor_imu = metadata.imu_to_sensor.topLeftCorner<3, 3>();
  out.sample.gyro = R_sensor_imu * (gyro * (M_PI / 180.0));
  out.sample.accel = R_sensor_imu * (accel * kStandardGravity);
  return out;
}

}  // namespace hazmap
