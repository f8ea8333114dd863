#pragma once
// Trajectories: KITTI (12 numbers per line: row-major 3×4 [R|t]) and TUM
// (`timestamp tx ty tz qx qy qz qw`, '#' comments allowed).
#include <Eigen/Geometry>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace hazmap {

struct Trajectory {
  std::vector<double> stamps;  ///< seconds; for KITTI files the frame index
  std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> poses;
  std::size_t size() const { return poses.size(); }
  bool empty() const { return poses.empty(); }
  void push_back(double stamp, const Eigen::Isometry3d& pose) {
    stamps.push_back(stamp);
    poses.push_back(pose);
  }
};

enum class TrajectoryFormat { Kitti, Tum };

Trajectory readKittiTrajectory(const std::filesystem::path& path);
Trajectory readTumTrajectory(const std::filesystem::path& path);
Trajectory readTrajectory(const std::filesystem::path& path, TrajectoryFormat format);
/// The format by content: 12 numbers on the first data line → KITTI, 8 → TUM; nullopt for a
/// file without data lines or with another count. Throws hazmap::Error if it cannot be read.
std::optional<TrajectoryFormat> detectTrajectoryFormat(const std::filesystem::path& path);
/// Guesses by content: 12 numbers per line → KITTI, 8 → TUM.
Trajectory readTrajectoryAuto(const std::filesystem::path& path);

void writeKittiTrajectory(const std::filesystem::path& path, const Trajectory& trajectory);
void writeTumTrajectory(const std::filesystem::path& path, const Trajectory& trajectory);

}  // namespace hazmap
