// GlobalMapConfig and HazardConfig: their field tables (core/config_fields.hpp) and the YAML
// entry points derived from them.
#include "hazmap/core/config_fields.hpp"
#include "hazmap/map/global_map.hpp"
#include "hazmap/map/hazards.hpp"

namespace hazmap {

const ConfigFields<GlobalMapConfig>& configFields(ConfigTag<GlobalMapConfig>) {
  using C = GlobalMapConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("The global map: one cell per occupied voxel with class votes, bounded in memory.")
          .number("voxel_size", &C::voxel_size, positive(), "m; initial cell size")
          .integer("max_voxels", &C::max_voxels, atLeast(1000), "Cap on cells; beyond it the grid coarsens ×2")
          .number("min_range", &C::min_range, nonNegative(), "m; closer scan points are ignored")
          .number("max_range", &C::max_range, nonNegative(), "m; farther points are ignored (0 = keep all)")
          .integer("max_frame_ranges", &C::max_frame_ranges, atLeast(1),
                   "Frame ranges kept per property voxel (beyond it the closest two merge)")
          .rule("max_range", [](const C& c) { return c.max_range == 0 || c.max_range > c.min_range; },
                "must be larger than min_range (or 0 for no limit)");
  return fields;
}

const ConfigFields<HazardConfig>& configFields(ConfigTag<HazardConfig>) {
  using C = HazardConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Hazard regions: connected property cells of the global map.")
          .integer("link_cells", &C::link_cells, closed(1, 5),
                   "Cells closer than this many cells (Chebyshev) join one region")
          .integer("min_cells", &C::min_cells, atLeast(1), "Smaller regions are dropped as noise")
          .integer("min_points", &C::min_points, nonNegative(), "Regions with fewer scan points are dropped");
  return fields;
}

void GlobalMapConfig::validate() const { validateConfig(*this, "map"); }
void HazardConfig::validate() const { validateConfig(*this, "hazards"); }

GlobalMapConfig GlobalMapConfig::fromYamlString(const std::string& yaml, const std::string& where) {
  return configFromYaml(yaml, where, "map", GlobalMapConfig{});
}

HazardConfig HazardConfig::fromYamlString(const std::string& yaml, const std::string& where) {
  return configFromYaml(yaml, where, "hazards", HazardConfig{});
}

}  // namespace hazmap
