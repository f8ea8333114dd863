#include "hazmap/core/labeled_cloud.hpp"

#include <cmath>
#include <string>

#include "hazmap/core/error.hpp"

namespace hazmap {

LabeledCloud LabeledCloud::withLayoutOf(const LabeledCloud& other) {
  LabeledCloud out;
  if (other.hasIntensity()) out.enableIntensity();
  if (other.hasTimestamps()) out.enableTimestamps();
  if (other.hasProperty()) out.enableProperty();
  return out;
}

void LabeledCloud::reserve(std::size_t n) {
  points.reserve(n);
  classes.reserve(n);
  if (hasIntensity()) intensity.reserve(n);
  if (hasTimestamps()) timestamps.reserve(n);
  if (hasProperty()) property.reserve(n);
}

void LabeledCloud::clear() {
  if (!intensity.empty()) enabled_ |= kIntensity;
  if (!timestamps.empty()) enabled_ |= kTimestamps;
  if (!property.empty()) enabled_ |= kProperty;
  points.clear();
  classes.clear();
  intensity.clear();
  timestamps.clear();
  property.clear();
}

void LabeledCloud::resize(std::size_t n) {
  const bool i = hasIntensity(), t = hasTimestamps(), p = hasProperty();
  points.resize(n, Eigen::Vector3f::Zero());
  classes.resize(n, 0);
  if (i) intensity.resize(n, 0.0f);
  if (t) timestamps.resize(n, 0.0);
  if (p) property.resize(n, 0.0f);
}

void LabeledCloud::push_back(const Eigen::Vector3f& p, ClassId c, float intensity_value,
                             double time, float property_value) {
  if (hasIntensity()) intensity.push_back(intensity_value);
  if (hasTimestamps()) timestamps.push_back(time);
  if (hasProperty()) property.push_back(property_value);
  points.push_back(p);
  classes.push_back(c);
}

void LabeledCloud::pushFrom(const LabeledCloud& other, std::size_t i) {
  push_back(other.points[i], other.classes[i], other.hasIntensity() ? other.intensity[i] : 0.0f,
            other.hasTimestamps() ? other.timestamps[i] : 0.0,
            other.hasProperty() ? other.property[i] : 0.0f);
}

LabeledCloud LabeledCloud::select(std::span<const std::size_t> indices) const {
  LabeledCloud out = withLayoutOf(*this);
  out.reserve(indices.size());
  for (std::size_t i : indices) out.pushFrom(*this, i);
  return out;
}

LabeledCloud LabeledCloud::slice(std::size_t begin, std::size_t end) const {
  end = std::min(end, size());
  begin = std::min(begin, end);
  LabeledCloud out = withLayoutOf(*this);
  out.points.assign(points.begin() + begin, points.begin() + end);
  out.classes.assign(classes.begin() + begin, classes.begin() + end);
  if (hasIntensity()) out.intensity.assign(intensity.begin() + begin, intensity.begin() + end);
  if (hasTimestamps())
    out.timestamps.assign(timestamps.begin() + begin, timestamps.begin() + end);
  if (hasProperty()) out.property.assign(property.begin() + begin, property.begin() + end);
  return out;
}

void LabeledCloud::append(const LabeledCloud& other) {
  if (empty() && !hasIntensity() && !hasTimestamps() && !hasProperty()) {
    *this = other;
    return;
  }
  const bool i = hasIntensity() && other.hasIntensity();
  const bool t = hasTimestamps() && other.hasTimestamps();
  const bool p = hasProperty() && other.hasProperty();
  if (!i) { intensity.clear(); enabled_ &= ~kIntensity; }
  if (!t) { timestamps.clear(); enabled_ &= ~kTimestamps; }
  if (!p) { property.clear(); enabled_ &= ~kProperty; }
  points.insert(points.end(), other.points.begin(), other.points.end());
  classes.insert(classes.end(), other.classes.begin(), other.classes.end());
  if (i) intensity.insert(intensity.end(), other.intensity.begin(), other.intensity.end());
  if (t) timestamps.insert(timestamps.end(), other.timestamps.begin(), other.timestamps.end());
  if (p) property.insert(property.end(), other.property.begin(), other.property.end());
}

void LabeledCloud::transform(const Eigen::Isometry3d& T) {
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  for (auto& p : points) p = R * p + t;
}

LabeledCloud LabeledCloud::transformed(const Eigen::Isometry3d& T) const {
  LabeledCloud out = *this;
  out.transform(T);
  return out;
}

std::size_t LabeledCloud::removeNonFinite() {
  const bool i = hasIntensity(), t = hasTimestamps(), p = hasProperty();
  std::size_t w = 0;
  for (std::size_t r = 0; r < size(); ++r) {
    const bool ok = points[r].allFinite() && (!i || std::isfinite(intensity[r])) &&
                    (!t || std::isfinite(timestamps[r])) && (!p || std::isfinite(property[r]));
    if (!ok) continue;
    if (w != r) {
      points[w] = points[r];
      classes[w] = classes[r];
      if (i) intensity[w] = intensity[r];
      if (t) timestamps[w] = timestamps[r];
      if (p) property[w] = property[r];
    }
    ++w;
  }
  const std::size_t dropped = size() - w;
  points.resize(w);
  classes.resize(w);
  if (i) intensity.resize(w);
  if (t) timestamps.resize(w);
  if (p) property.resize(w);
  return dropped;
}

AxisAlignedBox LabeledCloud::bounds() const {
  AxisAlignedBox box;
  for (const auto& p : points) box.extend(p);
  return box;
}

void LabeledCloud::checkConsistent(const std::string& where) const {
  const auto check = [&](std::size_t n, const char* name, bool optional) {
    if (n != size() && !(optional && n == 0))
      fail(where, std::string(name) + " count " + std::to_string(n) + " differs from point count " +
                      std::to_string(size()));
  };
  check(classes.size(), "class", false);
  check(intensity.size(), "intensity", true);
  check(timestamps.size(), "timestamp", true);
  check(property.size(), "property value", true);
}

}  // namespace hazmap
