#include "hazmap/map/export.hpp"

#include <algorithm>
#include <cmath>

#include "hazmap/core/error.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/io/ply.hpp"

namespace hazmap {

Rgb propertyColor(const ClassInfo& info, const MapColorConfig& config) {
  switch (info.kind) {
    case PropertyKind::Heat: return config.heat;
    case PropertyKind::Water: return config.water;
    case PropertyKind::Radiation: return config.radiation;
    default: return info.color;
  }
}

std::pair<double, double> heightRange(const LabeledCloud& cloud, const ClassTable& table,
                                      const MapColorConfig& config) {
  std::vector<float> z;
  z.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (!table.isProperty(cloud.classes[i]) && std::isfinite(cloud.points[i].z()))
      z.push_back(cloud.points[i].z());
  if (z.empty())
    for (const auto& p : cloud.points)
      if (std::isfinite(p.z())) z.push_back(p.z());
  if (z.empty()) return {0.0, 1.0};
  const auto at = [&](double q) {
    const std::size_t k = std::min(z.size() - 1, std::size_t(std::clamp(q, 0.0, 1.0) * double(z.size() - 1)));
    std::nth_element(z.begin(), z.begin() + std::ptrdiff_t(k), z.end());
    return double(z[k]);
  };
  const double lo = at(config.low_percentile), hi = at(config.high_percentile);
  return hi > lo ? std::pair{lo, hi} : std::pair{lo - 0.5, lo + 0.5};
}

Rgb greyForHeight(double z, double lo, double hi, const MapColorConfig& config) {
  const double t = std::clamp((z - lo) / std::max(1e-9, hi - lo), 0.0, 1.0);
  Rgb c;
  for (int k = 0; k < 3; ++k)
    c[k] = std::uint8_t(std::lround(config.grey_low[k] + t * (config.grey_high[k] - config.grey_low[k])));
  return c;
}

std::vector<Rgb> mapColors(const LabeledCloud& cloud, const ClassTable& table, const MapColorConfig& config) {
  const auto [lo, hi] = heightRange(cloud, table, config);
  std::vector<Rgb> colors(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const ClassInfo* info = table.find(cloud.classes[i]);
    colors[i] = (info && info->kind != PropertyKind::None)
                    ? propertyColor(*info, config)
                    : greyForHeight(cloud.points[i].z(), lo, hi, config);
  }
  return colors;
}

void writeMapPly(const std::filesystem::path& path, const LabeledCloud& map, const ClassTable& table,
                 const MapColorConfig& config, std::vector<std::pair<std::string, std::vector<float>>> fields) {
  map.checkConsistent(path.string());
  PlyWriteOptions options;
  options.binary = true;
  options.colors = mapColors(map, table, config);
  options.fields = std::move(fields);
  writePly(path, map, options);
}

void writeMapPcd(const std::filesystem::path& path, const LabeledCloud& map) {
  map.checkConsistent(path.string());
  writePcd(path, map, PcdEncoding::Binary);
}

}  // namespace hazmap
