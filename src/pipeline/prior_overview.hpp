#pragma once
// The search overview of a map folder (map/map_folder.hpp, "search_overview"): every keyframe
// downsampled, placed at its pose, and the union downsampled again — the cloud whose FPFH
// features a later mission's global registration searches (pipeline/prior_search.hpp). Made
// the same way whether a run writes it into its map folder or a reader rebuilds it from the
// keyframes, so a localisation does not depend on which of the two it used.
#include <Eigen/Geometry>
#include <filesystem>
#include <optional>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/map/map_folder.hpp"

namespace hazmap::pipeline_detail {

/// m: both downsamplings of the overview (the global registration downsamples to 0.5 m anyway).
constexpr double kOverviewVoxel = 0.25;

/// `cloud` at `voxel`, a voxel's class voted with property classes preferred: how the prior's
/// pieces (the overview, the verification's keyframe clouds) are downsampled.
LabeledCloud downsampledForPrior(const LabeledCloud& cloud, double voxel, const ClassTable& classes);

/// One keyframe's contribution (sensor frame): its cloud at kOverviewVoxel.
LabeledCloud keyframeOverview(const LabeledCloud& full, const ClassTable& classes);

/// Points the union may hold before it is downsampled on the way (about 60 MB): a map of up to
/// about 330 keyframes is downsampled once, as a whole; a longer mission's in steps, so a save at
/// the end of an hour does not hold every keyframe's points at once.
constexpr std::size_t kOverviewUnionPoints = 2'000'000;

/// The keyframes' overviews placed at their poses (in order) and downsampled again (whenever the
/// union exceeds kOverviewUnionPoints, and at the end). The same calls give the same bits.
class SearchOverviewBuilder {
 public:
  explicit SearchOverviewBuilder(const ClassTable& classes) : classes_(classes) {}
  void add(const LabeledCloud& keyframe_overview, const Eigen::Isometry3d& pose);
  LabeledCloud finish() const;

 private:
  const ClassTable& classes_;
  LabeledCloud all_;
};

/// Writes `overview` (a builder's, made with `classes`) as `dir`/search_overview.pcd (atomically)
/// and returns its key for the manifest.
MapSearchOverview writeSearchOverview(const std::filesystem::path& dir, const LabeledCloud& overview,
                                      const ClassTable& classes);
/// The same from the keyframes `manifest` lists in `dir` (clouds already written, read with
/// `map_classes`; downsampled with `classes`). Throws hazmap::Error naming a file that cannot be read.
MapSearchOverview writeSearchOverview(const std::filesystem::path& dir, const MapManifest& manifest,
                                      const ClassTable& map_classes, const ClassTable& classes);

/// `map`'s overview when it has one made as this build makes it with `classes` (same voxel,
/// same property classes); nullopt otherwise (rebuild it from the keyframes).
std::optional<LabeledCloud> storedSearchOverview(const MapFolder& map, const ClassTable& classes);

}  // namespace hazmap::pipeline_detail
