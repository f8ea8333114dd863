#pragma once
// GlobalMap: the world map assembled from posed scans, one cell per occupied voxel, keeping the
// physical-property classes (majority vote per voxel) and, for every voxel that received
// property points, which frames saw it (the hazard inventory reports them).
//
// Memory is bounded: when the number of voxels exceeds `max_voxels`, the grid coarsens (voxel
// size doubles, eight cells merge into one with their counts, votes and frame lists). A
// 10,000-frame run therefore never holds more than `max_voxels` cells, and still covers the
// whole explored area (at a coarser resolution) instead of forgetting old parts.
//
// Scans are inserted incrementally, frame by frame, in the sensor frame with T_world_sensor.
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "hazmap/core/config_fwd.hpp"
#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/io/sequence.hpp"

namespace hazmap {

struct GlobalMapConfig {
  double voxel_size = 0.1;            ///< m, initial cell size (> 0)
  std::size_t max_voxels = 2000000;   ///< cap on cells; beyond it the grid coarsens ×2 (>= 1000)
  double min_range = 0.0;             ///< m; scan points closer to the sensor are ignored
  double max_range = 0.0;             ///< m; farther points are ignored (0 = keep all)
  /// Frame ranges kept per property voxel; beyond it the two closest ranges merge (so a
  /// voxel's frame list may then include a few frames that did not see it). Exact counts of
  /// frames are kept regardless.
  std::size_t max_frame_ranges = 32;

  /// Reads the keys above from a YAML mapping (missing keys keep their defaults).
  /// `where` names the source in errors.
  static GlobalMapConfig fromYamlString(const std::string& yaml, const std::string& where);
  /// Throws hazmap::Error("global map: <param> ...") on an invalid value.
  void validate() const;
};

/// The field table (keys, ranges, docs; core/config_fields.hpp, docs/configuration.md).
const ConfigFields<GlobalMapConfig>& configFields(ConfigTag<GlobalMapConfig>);

/// Inclusive range of frame indices.
struct FrameRange {
  std::uint32_t first = 0, last = 0;
  bool operator==(const FrameRange&) const = default;
};
/// Number of frames in sorted, disjoint ranges.
std::size_t countFrames(const std::vector<FrameRange>& ranges);
/// Union of range lists (sorted, merged where they touch or overlap).
std::vector<FrameRange> unionRanges(std::vector<FrameRange> ranges);

/// One named channel over a cell's property-class points (NaN values ignored).
struct ChannelStats {
  float mean = 0, max = 0;        ///< 0 when no value arrived
  std::uint32_t samples = 0;      ///< how many values entered mean and max
};

/// Read-only view of one cell.
struct MapCell {
  Eigen::Vector3i index;               ///< integer voxel coordinates at the current voxel size
  Eigen::Vector3f centroid;            ///< mean of the points that fell in the cell
  std::uint32_t points = 0;
  ClassId label = 0;                   ///< majority class (ties → smaller id)
  std::uint32_t label_points = 0;      ///< points of the majority class
  float property_mean = 0;             ///< mean property value of property-class points
  std::uint32_t property_samples = 0;  ///< how many values entered property_mean
  float property_max = 0;              ///< largest of those values (0 when none)
  std::vector<FrameRange> frames;      ///< frames that put property points here (may be empty)
  std::uint32_t frame_count = 0;       ///< exact number of such frames
  std::vector<ChannelStats> channels;  ///< per GlobalMap::channelNames() entry (empty without named channels)
};

class GlobalMap {
 public:
  explicit GlobalMap(GlobalMapConfig config = {}, ClassTable table = ClassTable::defaults());
  ~GlobalMap();
  GlobalMap(GlobalMap&&) noexcept;
  GlobalMap& operator=(GlobalMap&&) noexcept;

  /// Adds a scan (sensor frame) seen at `frame` with pose T_world_sensor. Frames may come in
  /// any order, but inserting the same frame twice counts its points twice. Non-finite points
  /// are skipped; a non-finite pose or a class missing from the table throws hazmap::Error.
  /// `channels`: the scan's named channels (Scan::channels, one value per scan point); each
  /// property-class point adds its finite values to its cell's mean and max of that channel.
  void insert(std::size_t frame, const LabeledCloud& scan, const Eigen::Isometry3d& T_world_sensor,
              std::span<const PointChannel> channels = {});

  /// Adds every cell of `part` (a map of other frames, built in another frame: `T_this_part`
  /// maps its coordinates into this map's) with its counts, class votes, property and channel
  /// sums and frame lists, as if its points had been inserted here; its frames and points add
  /// to this map's counts. A cell lands whole in the cell its centroid moves to: exact when
  /// `T_this_part` is the identity and both maps share the cell size, within a cell otherwise
  /// (re-placing a map after a loop correction instead of rebuilding it, map/segmented_map.hpp).
  /// Throws hazmap::Error for a non-finite transform or another class table.
  void insertMap(const GlobalMap& part, const Eigen::Isometry3d& T_this_part);

  std::size_t size() const;          ///< occupied cells
  std::size_t frames() const;        ///< insert() calls
  std::size_t pointsInserted() const;
  double voxelSize() const;          ///< current cell size (grows when the map coarsens)
  int coarsenings() const;           ///< how many times the grid doubled its cell size
  const GlobalMapConfig& config() const;
  const ClassTable& classTable() const;
  /// Named channels seen so far, in order of first appearance (MapCell::channels' order).
  const std::vector<std::string>& channelNames() const;
  /// Approximate heap bytes used by the cells (for benchmarks / run.json).
  std::size_t memoryBytes() const;

  /// All cells, sorted by voxel index (deterministic).
  std::vector<MapCell> cells() const;
  /// One point per cell at its centroid, with its majority class, and the property channel
  /// (mean value) when any inserted scan had one. Same order as cells().
  LabeledCloud cloud() const;
  AxisAlignedBox bounds() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hazmap
