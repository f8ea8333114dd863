#include "viewer_data.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <numeric>
#include <random>

namespace hazmap::viewer {

namespace {

constexpr std::size_t kRawBytesPerPoint = 3 * 2 + 3;  // uint16 x y z + rgb

// Finite points, shuffled with a fixed seed (same page for the same map), cut to max_points,
// then grouped by class with the shuffled order kept inside each group.
std::vector<std::size_t> chosenPoints(const LabeledCloud& map, std::size_t max_points) {
  std::vector<std::size_t> order;
  order.reserve(map.size());
  for (std::size_t i = 0; i < map.size(); ++i)
    if (map.points[i].allFinite()) order.push_back(i);
  std::mt19937_64 rng(0x68617a6d6170ULL);
  for (std::size_t i = order.size(); i > 1; --i)  // Fisher-Yates: the same on every platform
    std::swap(order[i - 1], order[std::size_t(rng() % i)]);
  if (max_points > 0 && order.size() > max_points) order.resize(max_points);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return map.classes[a] < map.classes[b]; });
  return order;
}

template <typename T>
void appendLittleEndian(std::vector<std::uint8_t>& out, T value) {
  std::uint8_t bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(bytes, bytes + sizeof(T));
  out.insert(out.end(), bytes, bytes + sizeof(T));
}

std::vector<PointGroup> groupsOf(const ViewerScene& scene, const std::vector<std::size_t>& order) {
  std::vector<PointGroup> groups;
  for (std::size_t k = 0; k < order.size(); ++k) {
    const ClassId c = scene.map.classes[order[k]];
    if (groups.empty() || groups.back().id != c) {
      PointGroup g;
      g.id = c;
      g.offset = k;
      const ClassInfo* info = scene.classes.find(c);
      g.name = info ? info->name : "class " + std::to_string(c);
      g.kind = info ? toString(info->kind) : "none";
      g.color = info ? propertyColor(*info, scene.colors) : Rgb{160, 160, 160};
      groups.push_back(g);
    }
    ++groups.back().count;
  }
  return groups;
}

}  // namespace

std::size_t bytesPerPoint(bool with_property) {
  return ((with_property ? kRawBytesPerPoint + 4 : kRawBytesPerPoint) * 4 + 2) / 3;
}

std::string base64(const std::uint8_t* data, std::size_t size) {
  static constexpr char kTable[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (std::size_t i = 0; i < size; i += 3) {
    const std::uint32_t b = std::uint32_t(data[i]) << 16 | (i + 1 < size ? std::uint32_t(data[i + 1]) << 8 : 0) |
                            (i + 2 < size ? std::uint32_t(data[i + 2]) : 0);
    out += kTable[(b >> 18) & 63];
    out += kTable[(b >> 12) & 63];
    out += i + 1 < size ? kTable[(b >> 6) & 63] : '=';
    out += i + 2 < size ? kTable[b & 63] : '=';
  }
  return out;
}

EncodedPoints encodePoints(const ViewerScene& scene, std::size_t max_points) {
  const LabeledCloud& map = scene.map;
  map.checkConsistent(scene.source.empty() ? "viewer map" : scene.source);
  EncodedPoints e;
  const std::vector<std::size_t> order = chosenPoints(map, max_points);
  e.total = std::count_if(map.points.begin(), map.points.end(), [](const auto& p) { return p.allFinite(); });
  e.embedded = order.size();
  e.has_property = map.hasProperty() && !map.property.empty();
  e.groups = groupsOf(scene, order);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(order.empty() ? 0.0 : INFINITY), hi = -lo;
  for (std::size_t i : order) {
    lo = lo.cwiseMin(map.points[i].cast<double>());
    hi = hi.cwiseMax(map.points[i].cast<double>());
  }
  e.qmin = lo;
  e.qstep = ((hi - lo) / 65535.0).cwiseMax(1e-9);
  e.center = 0.5 * (lo + hi);
  const std::vector<Rgb> colors = mapColors(map, scene.classes, scene.colors);  // as map.ply
  std::vector<std::uint8_t> xyz, rgb, property;
  xyz.reserve(order.size() * 6);
  rgb.reserve(order.size() * 3);
  for (std::size_t i : order) {
    for (int k = 0; k < 3; ++k) {
      const double q = std::round((double(map.points[i][k]) - e.qmin[k]) / e.qstep[k]);
      appendLittleEndian(xyz, std::uint16_t(std::clamp(q, 0.0, 65535.0)));
      rgb.push_back(colors[i][k]);
    }
    if (e.has_property) appendLittleEndian(property, float(map.property[i]));
  }
  e.positions = base64(xyz.data(), xyz.size());
  e.colors = base64(rgb.data(), rgb.size());
  if (e.has_property) e.property = base64(property.data(), property.size());
  return e;
}

}  // namespace hazmap::viewer
