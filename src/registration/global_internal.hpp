#pragma once
// Building blocks of global registration (include/hazmap/registration/global_registration.hpp):
// FPFH features, descriptor index, property landmarks, hypothesis generation and scoring.
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "hazmap/preprocess/spatial_index.hpp"
#include "hazmap/registration/global_registration.hpp"
#include "hazmap/registration/registration_target.hpp"

namespace hazmap::global {

constexpr int kBins = 11;              ///< per angle, as in the FPFH paper
constexpr int kDescriptorSize = 3 * kBins;
using Descriptor = std::array<float, kDescriptorSize>;

/// A cluster of same-class property points (centroid in the cloud's frame).
struct Landmark {
  ClassId cls = 0;
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  std::size_t points = 0;
};

/// A downsampled cloud with normals and FPFH descriptors of the points that have one.
struct FeatureCloud {
  LabeledCloud cloud;
  std::vector<Eigen::Vector3f> normals;
  std::vector<Descriptor> descriptors;   ///< one per entry of feature_point
  std::vector<std::uint32_t> feature_point;  ///< cloud index of each descriptor
  /// Cloud indices of property-class points in landmarks (isolated labels are label noise).
  std::vector<std::uint32_t> labelled;
  std::vector<Landmark> landmarks;
  std::unique_ptr<NeighborIndex> index;  ///< all points of `cloud`
};

/// Downsample (property-preferring vote), crop to max_range, normals towards `viewpoint`, FPFH.
FeatureCloud computeFeatures(const LabeledCloud& raw, const ClassTable& classes,
                             const GlobalRegistrationConfig& config, const Eigen::Vector3f& viewpoint);

/// Nearest neighbour in descriptor space (k-d tree, exact) over a subset of descriptors.
class DescriptorIndex {
 public:
  DescriptorIndex(const std::vector<Descriptor>& descriptors, std::vector<std::uint32_t> ids);
  ~DescriptorIndex();
  DescriptorIndex(DescriptorIndex&&) noexcept;
  DescriptorIndex& operator=(DescriptorIndex&&) noexcept;
  /// Descriptor id (index into the vector given at construction) of the nearest, -1 if empty.
  std::int64_t nearest(const Descriptor& query) const;
  std::size_t size() const { return ids_.size(); }

 private:
  struct Impl;
  std::vector<std::uint32_t> ids_;
  std::unique_ptr<Impl> impl_;
};

/// Descriptor indexes of one cloud: all descriptors, and (property-aware) one per property class.
struct DescriptorIndexes {
  std::optional<DescriptorIndex> all;
  std::map<ClassId, DescriptorIndex> by_class;
};
DescriptorIndexes indexDescriptors(const FeatureCloud& fc, const ClassTable& classes, bool use_classes);
/// Nearest descriptor id for a point of class `cls`: within its own class when that is a
/// property class and use_classes (-1 when the other cloud has none of it), else among all.
std::int64_t nearestFor(const Descriptor& d, ClassId cls, const DescriptorIndexes& idx, const ClassTable& classes,
                        bool use_classes);

/// `members` (optional) receives the cloud indices of the points of the landmarks kept, sorted.
std::vector<Landmark> clusterLandmarks(const LabeledCloud& cloud, const ClassTable& classes,
                                       std::vector<std::uint32_t>* members = nullptr);

/// A descriptor match: cloud indices of the source and target point.
struct Match {
  std::uint32_t source = 0, target = 0;
};

struct Hypothesis {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  double votes = 0.0;  ///< agreeing matches (RANSAC) or landmark pairs (constellations)
  bool constellation = false;
};

/// RANSAC over triples of matches with the edge-length pre-check; returns the best hypotheses
/// (each re-fitted on its agreeing matches), best first, pairwise distinct.
std::vector<Hypothesis> ransacHypotheses(const std::vector<Eigen::Vector3f>& source_points,
                                         const std::vector<Eigen::Vector3f>& target_points,
                                         const std::vector<Match>& matches,
                                         const GlobalRegistrationConfig& config, std::size_t keep);
/// Triples of same-class landmarks whose pairwise distances agree, best first, distinct.
std::vector<Hypothesis> constellationHypotheses(const std::vector<Landmark>& source,
                                                const std::vector<Landmark>& target,
                                                const GlobalRegistrationConfig& config, std::size_t keep);

/// True when a and b differ by more than kDistinctTranslation or kDistinctRotationDeg.
bool distinct(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b);
/// Least-squares rigid transform dst ← src (Kabsch/Umeyama without scale).
Eigen::Isometry3d fitRigid(const std::vector<Eigen::Vector3f>& src, const std::vector<Eigen::Vector3f>& dst);

}  // namespace hazmap::global

namespace hazmap {

struct GlobalRegistrationTarget::Impl {
  global::FeatureCloud features;
  global::DescriptorIndexes descriptors;
  std::unique_ptr<NeighborIndex> overlap_points;  ///< all points, cells of inlier_distance (scoring)
  std::map<ClassId, std::unique_ptr<NeighborIndex>> class_points;  ///< property classes
  std::vector<global::Landmark> landmarks;
  std::optional<RegistrationTarget> icp;
  std::optional<RegistrationTarget> final_icp;  ///< at final_voxel_size (when > 0)
  GlobalRegistrationConfig config;  ///< what it was prepared with
};

}  // namespace hazmap
