#pragma once
// LabeledCloud: the point cloud every stage passes around. Structure of arrays: positions,
// per-point property class, and optional channels (intensity, timestamp, continuous property
// value such as temperature). An optional channel is either empty or exactly size() long.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <span>
#include <vector>

namespace hazmap {

using ClassId = std::uint16_t;

struct AxisAlignedBox {
  Eigen::Vector3f min = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  Eigen::Vector3f max = Eigen::Vector3f::Constant(-std::numeric_limits<float>::infinity());
  bool empty() const { return (min.array() > max.array()).any(); }
  void extend(const Eigen::Vector3f& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
};

class LabeledCloud {
 public:
  std::vector<Eigen::Vector3f> points;
  std::vector<ClassId> classes;
  std::vector<float> intensity;    ///< optional: empty or size()
  std::vector<double> timestamps;  ///< optional: seconds, empty or size()
  std::vector<float> property;     ///< optional continuous value (e.g. temperature, °C)

  std::size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
  bool hasIntensity() const { return (enabled_ & kIntensity) || !intensity.empty(); }
  bool hasTimestamps() const { return (enabled_ & kTimestamps) || !timestamps.empty(); }
  bool hasProperty() const { return (enabled_ & kProperty) || !property.empty(); }

  /// Enables an optional channel (existing points get 0), so push_back fills it from now on.
  void enableIntensity() { enabled_ |= kIntensity; intensity.resize(size(), 0.0f); }
  void enableTimestamps() { enabled_ |= kTimestamps; timestamps.resize(size(), 0.0); }
  void enableProperty() { enabled_ |= kProperty; property.resize(size(), 0.0f); }
  /// An empty cloud with the same optional channels as `other`.
  static LabeledCloud withLayoutOf(const LabeledCloud& other);

  void reserve(std::size_t n);
  void clear();
  void resize(std::size_t n);

  /// Appends one point; optional channels that are enabled get the given values.
  void push_back(const Eigen::Vector3f& p, ClassId c = 0, float intensity_value = 0.0f,
                 double time = 0.0, float property_value = 0.0f);

  /// Copies point `i` of `other` (same channel layout required) to the end of this cloud.
  void pushFrom(const LabeledCloud& other, std::size_t i);

  /// A new cloud holding the given points, in that order (all channels kept).
  LabeledCloud select(std::span<const std::size_t> indices) const;
  /// A new cloud of the contiguous range [begin, end).
  LabeledCloud slice(std::size_t begin, std::size_t end) const;

  /// Appends `other`. If this cloud is empty it takes other's channel layout; otherwise an
  /// optional channel survives only if both clouds have it.
  void append(const LabeledCloud& other);

  void transform(const Eigen::Isometry3d& T);
  LabeledCloud transformed(const Eigen::Isometry3d& T) const;

  /// Drops points with a NaN/Inf coordinate (or NaN channel value); returns how many were dropped.
  std::size_t removeNonFinite();

  AxisAlignedBox bounds() const;

  /// Throws hazmap::Error naming `where` if a channel's length differs from size().
  void checkConsistent(const std::string& where) const;

 private:
  enum : unsigned { kIntensity = 1, kTimestamps = 2, kProperty = 4 };
  unsigned enabled_ = 0;
};

}  // namespace hazmap
