// libFuzzer target: KITTI and TUM trajectory readers (and the format guess), and the single
// transform file (`hazmap register --init`), and a sequence's gravity.txt (same line format family).
#include <cmath>

#include "fuzz_input.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/gravity.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/io/transform_file.hpp"

namespace {
void check(const hazmap::Trajectory& t) {
  if (t.stamps.size() != t.poses.size()) std::abort();
  for (const auto& T : t.poses)
    if (!T.matrix().allFinite()) std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static hazmap::fuzz::MemFile file("fuzz.txt");
  const std::string& path = file.set(data, size);
  try { check(hazmap::readTrajectoryAuto(path)); } catch (const hazmap::Error&) {}
  try { check(hazmap::readKittiTrajectory(path)); } catch (const hazmap::Error&) {}
  try {
    const auto t = hazmap::readTumTrajectory(path);
    check(t);
    for (const auto& T : t.poses)  // TUM quaternions are normalised on read
      if (std::abs(T.linear().determinant() - 1.0) > 1e-6) std::abort();
  } catch (const hazmap::Error&) {
  }
  try {
    const Eigen::Isometry3d T = hazmap::readTransformFile(path);
    if (!T.matrix().allFinite() || std::abs(T.linear().determinant() - 1.0) > 1e-6) std::abort();
  } catch (const hazmap::Error&) {
  }
  try {
    for (const auto& g : hazmap::readGravityFile(path))  // unit, finite directions and σ > 0 only
      if (!g.down.allFinite() || std::abs(g.down.norm() - 1.0) > 1e-9 || !(g.sigma_deg > 0.0)) std::abort();
  } catch (const hazmap::Error&) {
  }
  return 0;
}
