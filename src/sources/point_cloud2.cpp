// sensor_msgs/PointCloud2 of any layout → LabeledCloud. The layout is described by the message
// itself (fields with offset, datatype, count; point_step; row_step; endianness), so every
// read goes through a field accessor checked once against point_step.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <optional>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/ros_messages.hpp"

namespace hazmap {
namespace {

std::size_t datatypeSize(std::uint8_t datatype) {
  static constexpr std::size_t kSizes[9] = {0, 1, 1, 2, 2, 4, 4, 4, 8};
  return datatype >= 1 && datatype <= 8 ? kSizes[datatype] : 0;
}

bool isInteger(std::uint8_t datatype) { return datatype >= 1 && datatype <= 6; }

/// Reads one field of one point as double, whatever its datatype and endianness.
struct FieldAccessor {
  std::uint32_t offset = 0;
  std::uint8_t datatype = 0;
  bool swap = false;

  template <class T>
  T load(const std::uint8_t* p) const {
    T v;
    std::memcpy(&v, p + offset, sizeof(T));
    if constexpr (sizeof(T) > 1) {
      if (swap) {
        std::uint8_t b[sizeof(T)];
        std::memcpy(b, &v, sizeof(T));
        std::reverse(b, b + sizeof(T));
        std::memcpy(&v, b, sizeof(T));
      }
    }
    return v;
  }
  double operator()(const std::uint8_t* point) const {
    switch (datatype) {
      case 1: return load<std::int8_t>(point);
      case 2: return load<std::uint8_t>(point);
      case 3: return load<std::int16_t>(point);
      case 4: return load<std::uint16_t>(point);
      case 5: return load<std::int32_t>(point);
      case 6: return load<std::uint32_t>(point);
      case 7: return load<float>(point);
      default: return load<double>(point);
    }
  }
};

std::optional<FieldAccessor> findField(const PointCloud2& msg, std::initializer_list<const char*> names,
                                       const std::string& where) {
  const bool swap = msg.is_bigendian != (std::endian::native == std::endian::big);
  for (const char* name : names) {
    for (const auto& f : msg.fields) {
      if (f.name != name) continue;
      const std::size_t size = datatypeSize(f.datatype);
      if (size == 0)
        fail(where, "PointCloud2 field '" + f.name + "' has unknown datatype " + std::to_string(f.datatype));
      if (f.count == 0) continue;
      if (static_cast<std::uint64_t>(f.offset) + size > msg.point_step)
        fail(where, "PointCloud2 field '" + f.name + "' at offset " + std::to_string(f.offset) +
                        " does not fit in point_step " + std::to_string(msg.point_step));
      return FieldAccessor{f.offset, f.datatype, swap};
    }
  }
  return std::nullopt;
}

void checkLayout(const PointCloud2& msg, const std::string& where) {
  if (msg.width == 0 || msg.height == 0) return;
  if (msg.point_step == 0) fail(where, "PointCloud2 with point_step 0");
  const std::uint64_t row_bytes = static_cast<std::uint64_t>(msg.width) * msg.point_step;
  if (msg.height > 1 && msg.row_step < row_bytes)
    fail(where, "PointCloud2 row_step " + std::to_string(msg.row_step) + " < width × point_step " +
                    std::to_string(row_bytes));
  const std::uint64_t stride = msg.height > 1 ? msg.row_step : row_bytes;
  const std::uint64_t needed = stride * (msg.height - 1) + row_bytes;
  if (needed > msg.data.size())
    fail(where, "PointCloud2 of " + std::to_string(msg.height) + "×" + std::to_string(msg.width) +
                    " points needs " + std::to_string(needed) + " data bytes, has " +
                    std::to_string(msg.data.size()));
}

/// How the per-point time field maps to absolute seconds: value × scale + offset. Drivers
/// disagree (float seconds relative to the stamp, uint32 ns relative, float64 absolute
/// seconds, …), so the unit and origin are told from the values and the header stamp.
struct TimeMapping {
  double scale = 1.0, offset = 0.0;
};

TimeMapping timeMapping(std::uint8_t datatype, double max_abs, double stamp) {
  // Relative times span one scan (< 1 s); absolute ones sit next to the stamp or are epoch
  // times. A stamp under 10 s (a simulation starting at 0) cannot tell them apart: relative.
  TimeMapping m;
  m.scale = isInteger(datatype) ? 1e-9 : 1.0;
  if (!isInteger(datatype) && max_abs > 1e12) m.scale = 1e-9;  // float nanoseconds
  const double seconds = max_abs * m.scale;
  const bool absolute = seconds > 1e8 || (stamp > 10.0 && std::abs(seconds - stamp) < 5.0);
  if (!absolute && !isInteger(datatype) && max_abs > 1e3) m.scale = 1e-9;  // relative float ns
  m.offset = absolute ? 0.0 : stamp;
  return m;
}

}  // namespace

LabeledCloud pointCloud2ToCloud(const PointCloud2& msg, const std::string& where) {
  checkLayout(msg, where);
  const auto x = findField(msg, {"x"}, where), y = findField(msg, {"y"}, where),
             z = findField(msg, {"z"}, where);
  if (!x || !y || !z) fail(where, "PointCloud2 without float x, y, z fields");
  const auto intensity = findField(msg, {"intensity", "reflectivity"}, where);
  const auto time = findField(msg, {"time", "t", "timestamp", "time_stamp"}, where);
  const auto label = findField(msg, {"class", "label"}, where);
  const auto property = findField(msg, {"property", "temperature"}, where);

  const std::size_t n = static_cast<std::size_t>(msg.width) * msg.height;
  const std::uint64_t stride = msg.height > 1 ? msg.row_step : std::uint64_t{msg.width} * msg.point_step;
  auto pointAt = [&](std::size_t i) {
    return msg.data.data() + stride * (i / msg.width) + std::uint64_t{msg.point_step} * (i % msg.width);
  };
  TimeMapping tm;
  if (time) {
    double max_abs = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double v = std::abs((*time)(pointAt(i)));
      if (std::isfinite(v)) max_abs = std::max(max_abs, v);
    }
    tm = timeMapping(time->datatype, max_abs, msg.header.stamp);
  }

  LabeledCloud cloud;
  if (intensity) cloud.enableIntensity();
  if (time) cloud.enableTimestamps();
  if (property) cloud.enableProperty();
  cloud.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* p = pointAt(i);
    const Eigen::Vector3f xyz(static_cast<float>((*x)(p)), static_cast<float>((*y)(p)),
                              static_cast<float>((*z)(p)));
    if (!xyz.allFinite() || (xyz.array() == 0.0f).all()) continue;  // NaN or no return
    const double raw_label = label ? (*label)(p) : 0.0;
    // SemanticKITTI-style labels keep the instance in the upper 16 bits.
    const ClassId c = raw_label >= 0.0 && raw_label < 4294967296.0
                          ? static_cast<ClassId>(static_cast<std::uint32_t>(raw_label) & 0xFFFFu)
                          : ClassId{0};
    cloud.push_back(xyz, c, intensity ? static_cast<float>((*intensity)(p)) : 0.0f,
                    time ? (*time)(p) * tm.scale + tm.offset : 0.0,
                    property ? static_cast<float>((*property)(p)) : 0.0f);
  }
  return cloud;
}

}  // namespace hazmap
