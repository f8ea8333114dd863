#pragma once
// The local map of frame-to-map odometry: a sparse voxel map in the world frame that keeps a few
// points per voxel *with their classes*, bounded to a radius around the robot. Property points are
// rare and carry the paper's signal, so a full voxel still accepts one by replacing an unlabelled
// point, as long as property points hold at most half of it.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/odometry/detail/voxel_key_index.hpp"
#include "hazmap/preprocess/normals.hpp"
#include "hazmap/registration/registration_target.hpp"

namespace hazmap {

struct LocalMapConfig {
  double voxel_size = 1.0;        ///< m (> 0)
  int max_points_per_voxel = 20;  ///< >= 1
  /// Points closer than this to a point already in the voxel are not added (m; 0 = off): keeps the
  /// map from filling with repeated returns of the same surface.
  double min_point_distance = 0.0;
  double max_distance = 100.0;    ///< m; voxels farther from the robot are dropped (> 0)
  /// Point-to-plane normals of map points are re-estimated whenever a voxel within
  /// normal_radius changed. > 0 caps how often one point's normal is re-estimated (after that it
  /// keeps it; a point without a normal is always retried): faster, but measured to cost
  /// accuracy on the simulated sequences (docs/registration.md), so the default is exact.
  int normal_updates = 0;
  void validate() const;
};

class LocalMap {
 public:
  explicit LocalMap(const LocalMapConfig& config = {});

  /// Adds `scan_world` (already in the world frame) and drops voxels farther than max_distance
  /// from `origin`. `table` tells which classes are properties. Deterministic.
  void integrate(const LabeledCloud& scan_world, const Eigen::Vector3d& origin, const ClassTable& table);
  /// The map follows a corrected trajectory (issue 14, after a pose-graph optimisation): every
  /// point is moved by `corrections[i]` (T_world_new · T_world_old⁻¹ of the scan) of the i-th
  /// integrate() call that added it, the voxels rebuilt and bounded around `origin`. Throws when
  /// `corrections` has fewer entries than integrate() calls so far.
  void reanchor(const std::vector<Eigen::Isometry3d>& corrections, const Eigen::Vector3d& origin,
                const ClassTable& table);
  /// Number of integrate() calls so far (the scans whose points the map may hold).
  std::size_t integrations() const { return integrations_; }
  /// Every point in the map (classes and property values kept), in a deterministic order.
  LabeledCloud cloud() const;
  /// The map as a registration target (the same points as cloud(), classes and values kept),
  /// equal to RegistrationTarget(cloud(), classes, config) up to ties among equidistant normal
  /// neighbours. Point-to-plane normals are cached per point; a point's normal is re-estimated
  /// only when its k-nearest-neighbour set may have changed since the last call: a point was
  /// added or removed closer than its k-th neighbour (or within normal_radius when it had fewer),
  /// or a voxel within normal_radius was dropped (see also normal_updates). The neighbours come
  /// from the map's own voxels. Deterministic, thread-count independent.
  /// `lazy_normals`: stale normals are estimated only when ICP first pairs a point with them
  /// (RegistrationTarget's lazy mode; same values, most never needed). Such a target reads the
  /// map: use it before the next integrate() or makeTarget(), as the odometry does.
  RegistrationTarget makeTarget(const ClassTable& classes, const RegistrationConfig& config,
                                bool lazy_normals = false);
  std::size_t size() const { return points_; }
  std::size_t voxels() const { return voxels_.size(); }
  bool empty() const { return points_ == 0; }
  void clear();

 private:
  struct Voxel {
    std::int64_t x, y, z;
    std::vector<Eigen::Vector3f> points;
    std::vector<ClassId> classes;
    std::vector<float> values;
    int property_points = 0;
    std::vector<Eigen::Vector3f> normals;  ///< cached, valid when normals_valid
    std::vector<std::uint8_t> updates;     ///< how often each point's normal was estimated
    /// Squared distance of each point's k-th normal neighbour (normal_radius² when it had fewer;
    /// < 0 = not estimated yet): a change farther away cannot alter its neighbour set.
    std::vector<float> reach2;
    std::vector<Eigen::Vector3f> delta;  ///< points added or removed since the last makeTarget()
    bool force = false;  ///< re-estimate every point (a neighbouring voxel was dropped)
    bool normals_valid = false;
    bool changed = false;  ///< modified during the current integrate()
    std::vector<std::uint32_t> origins;  ///< the integrate() call that added each point
    /// The 27 voxels around it, itself included, at neighbourSlot(dx, dy, dz) (-1 = none): kept
    /// as voxels come and go, so the staleness passes of a one-voxel normal ring (the default)
    /// read them instead of hashing 27 keys per changed or stale voxel.
    std::array<std::int32_t, 27> neighbours;
  };
  static constexpr int neighbourSlot(int dx, int dy, int dz) { return (dx + 1) * 9 + (dy + 1) * 3 + (dz + 1); }
  /// Links new voxel k; the voxels from `first_new` on are new too and link themselves.
  void linkNeighbours(std::uint32_t k, std::size_t first_new);
  void unlinkNeighbours(std::uint32_t k);
  void moveVoxel(std::uint32_t from, std::uint32_t to);
  /// The voxels of each stale voxel's normal ring (normal_offsets_ order, -1 = none), looked up
  /// once for the staleness check and read by every normal estimated in that voxel until the
  /// map changes (instead of a hash probe per point and ring voxel).
  struct NearVoxels {
    static constexpr std::int32_t kNotLookedUp = -2;  ///< a row's first entry: the voxel skipped it
    std::vector<std::int32_t> row_of;  ///< voxel → first entry in `voxels`, -1 = no row
    std::vector<std::int32_t> voxels;
    const std::int32_t* row(std::size_t k) const {
      if (row_of[k] < 0 || voxels[row_of[k]] == kNotLookedUp) return nullptr;
      return voxels.data() + row_of[k];
    }
  };
  void addScan(const LabeledCloud& scan, bool values, std::span<const std::uint32_t> origins, const ClassTable& table);
  static Voxel newVoxel(const std::array<std::int64_t, 3>& c);
  std::size_t insertIntoVoxel(Voxel& v, const Eigen::Vector3f& p, ClassId cls, float value, std::uint32_t origin,
                              const ClassTable& table) const;
  Eigen::Vector3f estimateNormal(Voxel& v, std::size_t i, const NormalConfig& nc, const std::int32_t* near) const;
  std::vector<std::array<std::int64_t, 3>> dropFarVoxels(const Eigen::Vector3d& origin);
  // The steps of makeTarget().
  LabeledCloud gatherPoints(const std::vector<std::size_t>& first) const;
  void useNormalSettings(const RegistrationConfig& config);
  void markStaleNormals(NearVoxels& near);
  void markStaleInVoxel(Voxel& v, std::vector<const Voxel*>& around, std::int32_t* near) const;
  void estimatePendingNormals(const std::vector<char>& pending, const NormalConfig& nc, const NearVoxels& near,
                              std::vector<Eigen::Vector3f>& normals);
  /// Marks the normals of every voxel within the normal ring of (x, y, z) stale.
  void invalidateAround(std::int64_t x, std::int64_t y, std::int64_t z, bool force);
  LocalMapConfig config_;
  std::vector<Voxel> voxels_;
  detail::VoxelKeyIndex index_;  ///< voxel key → position in voxels_
  std::size_t points_ = 0;
  std::size_t integrations_ = 0;
  double inverse_voxel_ = 1.0;
  float min_point_distance2_ = 0.0f;
  bool has_values_ = false;
  // settings the cached normals were estimated with (a change invalidates them all)
  int normal_neighbors_ = -1;
  double normal_radius_ = -1.0;
  int normal_ring_ = 1;  ///< voxels within this Chebyshev distance share normal neighbourhoods
  std::vector<std::array<int, 3>> normal_offsets_;  ///< the ring's voxels, nearest first
  int normal_offsets_ring_ = -1;
  /// Target point j → (voxel, point in voxel), for the last makeTarget()'s lazy normals.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> owner_;
};

}  // namespace hazmap
