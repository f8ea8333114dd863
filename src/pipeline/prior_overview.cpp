#include "pipeline/prior_overview.hpp"

#include "hazmap/io/pcd.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"

namespace hazmap::pipeline_detail {

namespace {

constexpr const char* kOverviewFile = "search_overview.pcd";

std::vector<ClassId> propertyClasses(const ClassTable& classes) {
  std::vector<ClassId> ids;
  for (ClassId id : classes.ids())
    if (classes.isProperty(id)) ids.push_back(id);
  return ids;
}

}  // namespace

LabeledCloud downsampledForPrior(const LabeledCloud& cloud, double voxel, const ClassTable& classes) {
  return voxelDownsample(cloud, propertyVoxels(voxel), classes);
}

LabeledCloud keyframeOverview(const LabeledCloud& full, const ClassTable& classes) {
  return downsampledForPrior(full, kOverviewVoxel, classes);
}

void SearchOverviewBuilder::add(const LabeledCloud& keyframe_overview, const Eigen::Isometry3d& pose) {
  if (all_.size() + keyframe_overview.size() > kOverviewUnionPoints) all_ = downsampledForPrior(all_, kOverviewVoxel, classes_);
  all_.append(keyframe_overview.transformed(pose));
}

LabeledCloud SearchOverviewBuilder::finish() const { return downsampledForPrior(all_, kOverviewVoxel, classes_); }

MapSearchOverview writeSearchOverview(const std::filesystem::path& dir, const MapManifest& manifest,
                                      const ClassTable& map_classes, const ClassTable& classes) {
  SearchOverviewBuilder builder(classes);
  for (const auto& k : manifest.keyframes)
    builder.add(keyframeOverview(readPcd(dir / k.cloud, map_classes), classes), k.pose);
  return writeSearchOverview(dir, builder.finish(), classes);
}

MapSearchOverview writeSearchOverview(const std::filesystem::path& dir, const LabeledCloud& overview,
                                      const ClassTable& classes) {
  writePcd(dir / kOverviewFile, overview, PcdEncoding::BinaryCompressed);
  return {kOverviewFile, kOverviewVoxel, propertyClasses(classes)};
}

std::optional<LabeledCloud> storedSearchOverview(const MapFolder& map, const ClassTable& classes) {
  const auto& stored = map.manifest().search_overview;
  if (!stored || stored->voxel != kOverviewVoxel || stored->property_classes != propertyClasses(classes))
    return std::nullopt;
  return map.loadSearchOverview();
}

}  // namespace hazmap::pipeline_detail
