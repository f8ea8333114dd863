#pragma once
// Map exports: map.ply coloured by class (heat red, water blue, radiation yellow, other
// property classes in their class-table colour, everything else grey shaded by height) and
// map.pcd (x y z label [property], readable by PCL). Both written atomically.
#include <filesystem>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap {

struct MapColorConfig {
  Rgb heat{230, 25, 25};
  Rgb water{25, 90, 235};
  Rgb radiation{245, 215, 0};
  Rgb grey_low{110, 110, 110};  ///< plain points at the low height percentile
  Rgb grey_high{220, 220, 220};  ///< plain points at the high height percentile
  double low_percentile = 0.02;  ///< heights below/above these percentiles saturate
  double high_percentile = 0.98;
};

/// Colour of a property kind (heat/water/radiation); the class-table colour for Other.
Rgb propertyColor(const ClassInfo& info, const MapColorConfig& config = {});
/// Height range [lo, hi] used for the grey shading (percentiles of z over plain points; falls
/// back to all points). Returns {0, 1} for an empty cloud.
std::pair<double, double> heightRange(const LabeledCloud& cloud, const ClassTable& table,
                                      const MapColorConfig& config = {});
/// Grey for height z in [lo, hi].
Rgb greyForHeight(double z, double lo, double hi, const MapColorConfig& config = {});
/// One colour per point. Classes missing from the table are treated as plain.
std::vector<Rgb> mapColors(const LabeledCloud& cloud, const ClassTable& table,
                           const MapColorConfig& config = {});

/// map.ply: binary PLY with x y z, label (class), red green blue [, property].
/// `fields`: further per-point float properties (PlyWriteOptions::fields).
void writeMapPly(const std::filesystem::path& path, const LabeledCloud& map, const ClassTable& table,
                 const MapColorConfig& config = {},
                 std::vector<std::pair<std::string, std::vector<float>>> fields = {});
/// map.pcd: binary PCD v0.7 with x y z label [property].
void writeMapPcd(const std::filesystem::path& path, const LabeledCloud& map);

}  // namespace hazmap
