#include "stress_sequences.hpp"

#include <cmath>
#include <cstdio>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/registration/registration.hpp"
#include "hazmap/sources/scan_source.hpp"

namespace hazmap::stress {
namespace {

Eigen::Isometry3d yawOnly(double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

// The reference chain: plain point-to-plane ICP at 0.2 m voxels with tight tolerances, each step
// from the previous one (no tracker under test takes part in it).
std::vector<Eigen::Isometry3d> fineChain(const std::vector<LabeledCloud>& scans, const ClassTable& table) {
  RegistrationConfig rc;
  rc.use_classes = false;
  rc.max_iterations = 100;
  rc.translation_tolerance = 1e-6;
  rc.rotation_tolerance = 1e-6;
  rc.coarse_source_points = 0;
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.2;
  std::vector<Eigen::Isometry3d> poses{Eigen::Isometry3d::Identity()};
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
  for (std::size_t i = 1; i < scans.size(); ++i) {
    const RegistrationResult r = registerScans(scans[i], scans[i - 1], step, table, vd, rc);
    if (!r.converged && r.termination != Termination::MaxIterations)
      fail("stress reference", "the fine registration of scan " + std::to_string(i) + " failed: " + r.reason);
    step = r.transform;
    poses.push_back(normalized(poses.back() * step));
  }
  return poses;
}

}  // namespace

Sequence kittiSequence(const std::filesystem::path& data, const ClassTable& table, int first, int count) {
  Sequence s;
  s.name = "KITTI";
  const auto dir = data / "kitti-semantic-sample";
  for (int i = first; i < first + count; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "%06d", i);
    const auto label = dir / "labels" / (std::string(name) + ".label");
    s.scans.push_back(readKittiScan(dir / "velodyne" / (std::string(name) + ".bin"),
                                    std::filesystem::exists(label) ? std::optional(label) : std::nullopt, table));
  }
  s.poses = fineChain(s.scans, table);
  s.reference = "fine ICP chain (0.2 m voxels, plain point-to-plane, tolerances 1e-6)";
  return s;
}

Sequence ousterSequence(const std::filesystem::path& data) {
  Sequence s;
  s.name = "Ouster OS-1-128";
  const auto dir = data / "sensors" / "ouster-os1-128";
  auto src = openScanSource(dir / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap");
  while (auto scan = src->next()) s.scans.push_back(std::move(scan->cloud));
  const Trajectory sdk = readKittiTrajectory(dir / "OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt");
  s.poses.assign(sdk.poses.begin(), sdk.poses.end());
  if (s.poses.size() != s.scans.size()) fail(dir.string(), "poses and scans differ in number");
  s.reference = "ouster-sdk's poses";
  return s;
}

Sequence dropFrames(const Sequence& seq, int k) {
  if (k < 1) fail("dropFrames", "k must be >= 1");
  Sequence out{seq.name + " every " + std::to_string(k) + ". scan", {}, {}, seq.reference};
  for (std::size_t i = 0; i < seq.scans.size(); i += static_cast<std::size_t>(k)) {
    out.scans.push_back(seq.scans[i]);
    out.poses.push_back(seq.poses[i]);
  }
  return out;
}

LabeledCloud turned(const LabeledCloud& scan, double yaw) { return scan.transformed(yawOnly(-yaw)); }

Sequence suddenYaw(const Sequence& seq, std::size_t at, double yaw) {
  char name[64];
  std::snprintf(name, sizeof name, " turned %.0f deg at scan %zu", yaw * 180.0 / M_PI, at);
  Sequence out{seq.name + name, {}, {}, seq.reference};
  for (std::size_t i = 0; i < seq.scans.size(); ++i) {
    const double y = i >= at ? yaw : 0.0;
    out.scans.push_back(y != 0.0 ? turned(seq.scans[i], y) : seq.scans[i]);
    out.poses.push_back(seq.poses[i] * yawOnly(y));
  }
  return out;
}

Sequence turning(const Sequence& seq, double yaw_per_step) {
  char name[64];
  std::snprintf(name, sizeof name, " turning %.0f deg per scan", yaw_per_step * 180.0 / M_PI);
  Sequence out{seq.name + name, {}, {}, seq.reference};
  for (std::size_t i = 0; i < seq.scans.size(); ++i) {
    const double y = yaw_per_step * static_cast<double>(i);
    out.scans.push_back(turned(seq.scans[i], y));
    out.poses.push_back(seq.poses[i] * yawOnly(y));
  }
  return out;
}

std::vector<StepError> stepErrors(const Sequence& seq, const std::vector<Eigen::Isometry3d>& estimate) {
  if (estimate.size() != seq.poses.size()) fail("stepErrors", "one estimated pose per scan expected");
  std::vector<StepError> out;
  for (std::size_t i = 1; i < estimate.size(); ++i) {
    const Eigen::Isometry3d want = seq.poses[i - 1].inverse() * seq.poses[i];
    const Eigen::Isometry3d got = estimate[i - 1].inverse() * estimate[i];
    const Eigen::Isometry3d d = want.inverse() * got;
    out.push_back({translationNorm(d), rotationAngle(d) * 180.0 / M_PI, rotationAngle(want) * 180.0 / M_PI});
  }
  return out;
}

}  // namespace hazmap::stress
