#pragma once
// Guess-free correlative search in x, y and yaw: where a query cloud fits a target cloud, found
// by scoring every place and heading rather than by matching descriptors. For scenes of
// identical objects (a field of tanks) every FPFH descriptor looks like every other and RANSAC's
// triples never come from one arrangement; a brute-force score over the structure's footprint
// does not care. The structure is a slice above the floor (a level robot: z, roll and pitch are
// the floor's); property labels score apart, so that a repeated layout's twin places — which the
// structure alone cannot tell — are told apart by what was seen where. The answer is a guess for
// a 6-DoF verification (property ICP), never a result on its own.
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap {

/// The target's footprint: likelihood fields of its structure and of each property class.
class CorrelativeTarget {
 public:
  CorrelativeTarget() = default;
  /// `cloud` in the target's frame (z up); its floor is the most populated 10 cm band below
  /// `sensor_z` (the mean height of the sensors that saw it).
  CorrelativeTarget(const LabeledCloud& cloud, double sensor_z, const ClassTable& classes);
  bool empty() const { return structure_[0].empty(); }

  struct Field {
    double x0 = 0.0, y0 = 0.0, cell = 0.0;
    int nx = 0, ny = 0;
    std::vector<float> value;  ///< row-major, exp(−d²/2σ²) of the nearest point, 0 beyond 3σ
    bool empty() const { return value.empty(); }
    float at(double x, double y) const;
  };
  /// The structure's field at level 0 (fine, 0.1 m), 1 (0.4 m) or 2 (rough, 1 m).
  const Field& structure(int level) const { return structure_[level]; }
  /// The field of a property class (nullptr when the target has none of it).
  const Field* labels(ClassId cls) const;
  double floorZ() const { return floor_z_; }

 private:
  Field structure_[3];
  std::vector<std::pair<ClassId, Field>> labels_;
  double floor_z_ = 0.0;
};

struct CorrelativeResult {
  bool success = false;
  std::string reason;  ///< why not, or what was found
  /// Target ← query: x, y, yaw found; z from the floors; roll and pitch zero.
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  double score = 0.0;         ///< structure share + label share of the best place
  double second_score = 0.0;  ///< of the best place distinct from it
  std::size_t structure_points = 0, label_points = 0;  ///< of the query, as scored
};

/// Searches headings and the places within `place_radius` of `places` (target frame: where the
/// query's sensor may be, e.g. the target's keyframe positions). The query is in its sensor's
/// frame (z up, floor below the origin). Refused (success false, with the reason) when the query
/// has too little structure, or when a place at least 1.5 m or 15° from the best scores within
/// 10 % of it (a twin the data cannot tell apart).
CorrelativeResult searchCorrelative(const LabeledCloud& query, const CorrelativeTarget& target,
                                    const std::vector<Eigen::Vector2d>& places, double place_radius,
                                    const ClassTable& classes);

}  // namespace hazmap
