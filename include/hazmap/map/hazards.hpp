#pragma once
// Hazard inventory: the property cells of a GlobalMap (cells whose majority class carries a
// physical property: heat, water, radiation, …) grouped per class into connected regions. One
// region is one hazard the operator should know about: where it is, how big, how hot/wet, and
// which frames saw it.
#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/config_fwd.hpp"
#include "hazmap/core/class_table.hpp"
#include "hazmap/map/global_map.hpp"

namespace hazmap {

struct HazardConfig {
  /// Cells closer than this many cells (Chebyshev distance) join one region; 1 = the 26
  /// neighbours, 2 bridges one-cell gaps (sparse returns on far surfaces).
  int link_cells = 2;
  std::size_t min_cells = 2;    ///< smaller regions are dropped as noise
  std::size_t min_points = 10;  ///< regions with fewer scan points are dropped as noise

  static HazardConfig fromYamlString(const std::string& yaml, const std::string& where);
  void validate() const;
};

/// The field table (keys, ranges, docs; core/config_fields.hpp, docs/configuration.md).
const ConfigFields<HazardConfig>& configFields(ConfigTag<HazardConfig>);

/// One named channel over a hazard's cells (property-class points only; NaN values ignored).
struct HazardChannel {
  std::string name;
  std::optional<double> mean, max;  ///< empty when no point of the hazard had a value
  std::size_t samples = 0;
};

struct Hazard {
  int id = 0;  ///< 1-based, in output order (class id, then size)
  ClassId label = 0;
  std::string class_name;
  PropertyKind kind = PropertyKind::None;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< point-weighted mean of its cells
  Eigen::Vector3d min = Eigen::Vector3d::Zero();       ///< bounding box of its cells (cell faces)
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
  Eigen::Vector3d extent() const { return max - min; }
  double area_m2 = 0;      ///< footprint: distinct occupied (x, y) cells × cell area
  std::size_t cells = 0;
  std::size_t points = 0;  ///< scan points that fell in its cells
  std::optional<double> mean_property;  ///< mean property value when scans carried one
  std::optional<double> max_property;   ///< largest property value (peak temperature, dose rate)
  std::vector<FrameRange> frames;       ///< frames that saw it (union over its cells)
  std::size_t frame_count = 0;
  /// Every named channel of the map (GlobalMap::channelNames()): the max temperature of a heat
  /// source beside its NIR reflectance, the peak dose rate, …
  std::vector<HazardChannel> channels;
};

/// Deterministic: regions are ordered by class id, then by point count (largest first), then
/// by position. Uses the map's own class table.
std::vector<Hazard> findHazards(const GlobalMap& map, const HazardConfig& config = {});

/// hazards.json: {"voxel_size", "count", "hazards": [{id, class, kind, centroid[3], min[3],
/// max[3], extent[3], area_m2, cells, points, mean_property|null, max_property|null, frame_count,
/// frames: [[first, last], …], channels: {NAME: {mean|null, max|null, samples}, …}}]}. Atomic.
/// A named channel of the map and the cameras that measured it (hazards.json's `channels`).
struct HazardChannelInfo {
  std::string name;
  std::vector<std::string> cameras;  ///< empty when not known (a sequence's own channel)
};

/// `channels` (when any): top-level "channels": [{"name", "cameras"}], which channels the map
/// stores per cell and per hazard, and which cameras gave them.
void writeHazardsJson(const std::filesystem::path& path, const std::vector<Hazard>& hazards,
                      double voxel_size, const std::vector<HazardChannelInfo>& channels = {});
/// hazards.csv: one row per hazard; frames as "first-last;first-last"; after max_property, two
/// columns per named channel, NAME_mean and NAME_max (empty when no value). Atomic.
void writeHazardsCsv(const std::filesystem::path& path, const std::vector<Hazard>& hazards);
std::string hazardsJson(const std::vector<Hazard>& hazards, double voxel_size, int indent = 2,
                        const std::vector<HazardChannelInfo>& channels = {});
/// Reads hazards.json back (the fields above; frames are kept as ranges). Throws hazmap::Error
/// naming the file on a missing file, broken JSON or a missing field.
std::vector<Hazard> readHazardsJson(const std::filesystem::path& path);

}  // namespace hazmap
