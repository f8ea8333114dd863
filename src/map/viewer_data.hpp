#pragma once
// The viewer's embedded map: points grouped by class, each group shuffled (so that drawing its
// first k points is an even decimation), positions quantised to 16 bits per axis over the map's
// bounding box, colours as in map.ply, property values as float32; all little-endian, base64.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "hazmap/map/viewer.hpp"

namespace hazmap::viewer {

struct PointGroup {
  ClassId id = 0;
  std::string name, kind;
  Rgb color{0, 0, 0};  ///< the class's property colour (legend swatch)
  std::size_t offset = 0, count = 0;
};

struct EncodedPoints {
  std::vector<PointGroup> groups;
  Eigen::Vector3d qmin = Eigen::Vector3d::Zero(), qstep = Eigen::Vector3d::Ones();
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  std::size_t total = 0, embedded = 0;
  bool has_property = false;
  std::string positions, colors, property;  ///< base64
};

/// Bytes each embedded point adds to the page (base64 included).
std::size_t bytesPerPoint(bool with_property);
/// Encodes up to max_points finite points of the scene's map (0 = all).
EncodedPoints encodePoints(const ViewerScene& scene, std::size_t max_points);
std::string base64(const std::uint8_t* data, std::size_t size);

}  // namespace hazmap::viewer
