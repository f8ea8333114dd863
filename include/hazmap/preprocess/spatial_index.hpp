#pragma once
// Radius-bounded nearest-neighbour search over a fixed point set, two interchangeable backends:
//  - VoxelHashIndex: points bucketed in a sparse voxel grid (open-addressing hash, points stored
//    contiguously per voxel). A query visits neighbour voxels in order of their lower-bound
//    distance and skips every voxel whose box is farther than the best hit so far, so the search
//    is exact within the radius and usually touches 1–4 voxels.
//  - KdTreeIndex: nanoflann k-d tree (the usual choice; kept for the comparison in the bench).
// Both are immutable after construction and safe to query from many threads.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace hazmap {

struct Neighbor {
  std::uint32_t index = 0;  ///< index into the point array given at construction
  float distance2 = 0.0f;
};

class NeighborIndex {
 public:
  virtual ~NeighborIndex() = default;
  /// Nearest point with squared distance < max_distance2, or -1. Sets distance2 when found.
  virtual std::int64_t nearest(const Eigen::Vector3f& q, float max_distance2,
                               float& distance2) const = 0;
  /// Up to k nearest points within max_distance2, sorted by distance (appended to `out`, which is
  /// cleared first).
  virtual void kNearest(const Eigen::Vector3f& q, int k, float max_distance2,
                        std::vector<Neighbor>& out) const = 0;
  virtual std::size_t size() const = 0;
};

class VoxelHashIndex final : public NeighborIndex {
 public:
  /// Indexes points[ids[i]] (all points when `ids` is empty). `max_radius` bounds the radius any
  /// query will use (it sizes the neighbour-voxel ring). cell_size > 0.
  VoxelHashIndex(std::span<const Eigen::Vector3f> points, std::span<const std::uint32_t> ids,
                 float cell_size, float max_radius);
  std::int64_t nearest(const Eigen::Vector3f& q, float max_distance2, float& distance2) const override;
  void kNearest(const Eigen::Vector3f& q, int k, float max_distance2,
                std::vector<Neighbor>& out) const override;
  std::size_t size() const override { return ids_.size(); }
  float cellSize() const { return cell_; }
  std::size_t voxels() const { return voxels_; }

 private:
  struct Offset {
    int dx, dy, dz;
    float lower_bound2;  ///< in cell units², min distance from any point of the centre voxel
  };
  struct Slot {
    std::uint64_t key;    ///< kEmpty = unused
    std::uint32_t begin;  ///< the voxel holds points_[begin, end) (while building: its voxel id)
    std::uint32_t end;
  };
  /// The voxel's slot, or nullptr when it holds no point.
  const Slot* findCell(std::int64_t x, std::int64_t y, std::int64_t z) const;

  float cell_, inv_cell_;
  std::vector<Eigen::Vector3f> points_;  ///< sorted by voxel
  std::vector<std::uint32_t> ids_;       ///< original index of points_[i]
  std::size_t voxels_ = 0;
  /// Open addressing; a voxel's key and its point range side by side, 16 bytes: a probe that
  /// finds the voxel has its range in the same cache line (no second lookup per visited voxel).
  std::vector<Slot> table_;
  std::uint64_t table_mask_ = 0;
  std::vector<Offset> offsets_;  ///< sorted by lower_bound2
  int ring_ = 1;                 ///< voxels within this Chebyshev distance can hold a neighbour
};

class KdTreeIndex final : public NeighborIndex {
 public:
  KdTreeIndex(std::span<const Eigen::Vector3f> points, std::span<const std::uint32_t> ids);
  ~KdTreeIndex() override;
  std::int64_t nearest(const Eigen::Vector3f& q, float max_distance2, float& distance2) const override;
  void kNearest(const Eigen::Vector3f& q, int k, float max_distance2,
                std::vector<Neighbor>& out) const override;
  std::size_t size() const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hazmap
