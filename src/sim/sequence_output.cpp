// Writing a simulated sequence directory (see writeSimulation in simulator.hpp).
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <charconv>
#include <chrono>
#include <cstdio>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/gravity.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/io/ply.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/io/temporary_folder.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/sim/simulator.hpp"

namespace hazmap::sim {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// scene.ply: one vertex triple per triangle so every face can carry its region's colour.
TriangleMesh coloredSceneMesh(const Scene& scene, const ClassTable& table) {
  TriangleMesh out;
  const auto& m = scene.mesh;
  out.vertices.reserve(3 * m.triangles.size());
  out.vertex_colors.reserve(3 * m.triangles.size());
  out.triangles.reserve(m.triangles.size());
  out.triangle_classes.reserve(m.triangles.size());
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    const ClassId c = t < m.triangle_classes.size() ? m.triangle_classes[t] : 0;
    const ClassInfo* info = table.find(c);
    const Rgb color = info ? info->color : Rgb{160, 160, 160};
    const int base = static_cast<int>(out.vertices.size());
    for (int k = 0; k < 3; ++k) {
      out.vertices.push_back(m.vertices[m.triangles[t][k]]);
      out.vertex_colors.push_back(color);
    }
    out.triangles.emplace_back(base, base + 1, base + 2);
    out.triangle_classes.push_back(c);
  }
  return out;
}

Trajectory toTrajectory(const PoseList& poses, const std::vector<RouteSample>& samples) {
  Trajectory t;
  for (std::size_t i = 0; i < poses.size(); ++i)
    t.push_back(i < samples.size() ? samples[i].time : static_cast<double>(i), poses[i]);
  return t;
}

std::string frameName(std::size_t i) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%06zu", i);
  return buf;
}

void writeTrueLabels(const fs::path& path, const std::vector<ClassId>& classes) {
  LabeledCloud labels;
  labels.points.resize(classes.size(), Eigen::Vector3f::Zero());
  labels.classes = classes;
  writeSemanticKittiLabels(path, labels);
}

/// Generates and writes every scan (in parallel batches); returns the reference cloud: every
/// scan placed with its true pose, with the true (noise-free) classes. It is ground truth, like
/// poses.txt; the scans themselves carry the label noise.
LabeledCloud writeScans(const Simulator& sim, SequenceWriter& writer, const fs::path& dir,
                        SimulationSummary& summary) {
  // The temperature channel is the sequence's property channel (hazmap.yaml names it): runs read
  // it, so a hotter source is observable (issue 34's value_changed).
  if (sim.config().temperature.enabled) writer.setPropertyChannel("temperature");
  // With cameras the noise-free classes are kept per scan too: they judge the camera labels.
  const bool true_labels = !sim.config().cameras.empty();
  if (true_labels) fs::create_directories(dir / "labels_true");
  LabeledCloud reference;
  const std::size_t n = sim.frames();
  const std::size_t batch = 32;
  std::vector<LabeledCloud> scans;
  std::vector<std::vector<ClassId>> truths;
  for (std::size_t begin = 0; begin < n; begin += batch) {
    const std::size_t end = std::min(n, begin + batch);
    scans.assign(end - begin, LabeledCloud{});
    truths.assign(end - begin, {});
    const auto t_scan = Clock::now();
    tbb::parallel_for(begin, end, [&](std::size_t i) { scans[i - begin] = sim.scan(i, &truths[i - begin]); });
    summary.scan_seconds += secondsSince(t_scan);
    const auto t_write = Clock::now();
    for (std::size_t i = begin; i < end; ++i) {
      const LabeledCloud& scan = scans[i - begin];
      writer.addFrame(scan);
      if (true_labels) writeTrueLabels(dir / "labels_true" / (frameName(i) + ".label"), truths[i - begin]);
      summary.points += scan.size();
      const Eigen::Isometry3f T = sim.groundTruth()[i].cast<float>();
      // No exact reserve here: growing by one scan at a time made every frame copy all before it
      // (quadratic: 1,330 scans of 28 k points did not finish in 10 minutes).
      for (std::size_t k = 0; k < scan.size(); ++k) {
        reference.points.push_back(T * scan.points[k]);
        reference.classes.push_back(truths[i - begin][k]);
      }
    }
    summary.write_seconds += secondsSince(t_write);
  }
  return reference;
}

void writeTrajectories(const Simulator& sim, SequenceWriter& writer, const fs::path& dir) {
  writer.writeGroundTruth(toTrajectory(sim.groundTruth(), sim.samples()));
  if (sim.config().wheel_odometry) writer.writeOdometry(toTrajectory(sim.odometry(), sim.samples()));
  std::ostringstream times;
  times.precision(9);
  for (std::size_t i = 0; i < sim.frames(); ++i) times << sim.samples()[i].time << "\n";
  writeTextAtomically(dir / "times.txt", times.str());
  if (sim.config().imu.enabled) {
    std::vector<GravitySample> gravity;
    for (std::size_t i = 0; i < sim.frames(); ++i) gravity.push_back(sim.gravity(i));
    writeGravityFile(dir / "gravity.txt", gravity);
  }
  if (sim.config().imu.rate_hz > 0.0) {
    std::vector<double> frame_times;
    for (const auto& s : sim.samples()) frame_times.push_back(s.time);
    writeImuFile(dir / "imu.txt", simulateImuStream(sim.worldPoses(), frame_times, sim.config().imu, sim.config().seed));
  }
}

/// reference_map.ply: the reference cloud downsampled, majority class per voxel, coloured.
void writeReferenceMap(const Simulator& sim, const LabeledCloud& reference, const fs::path& dir) {
  const ClassTable& table = sim.classTable();
  VoxelDownsampleConfig voxel;
  voxel.voxel_size = sim.config().reference_voxel;
  voxel.vote = ClassVote::Majority;
  const LabeledCloud map = voxelDownsample(reference, voxel, table);
  PlyWriteOptions ply;
  ply.colors.reserve(map.size());
  for (ClassId c : map.classes) {
    const ClassInfo* info = table.find(c);
    ply.colors.push_back(info ? info->color : Rgb{160, 160, 160});
  }
  writePly(dir / "reference_map.ply", map, ply);
}

/// simulation.yaml: the effective config, the run's statistics and the first scan's world pose.
std::string simulationInfo(const Simulator& sim, const SimulationSummary& summary) {
  std::ostringstream info;
  info << "# Effective configuration of `hazmap simulate` that wrote this sequence.\n"
       << sim.config().toYamlString() << "stats:\n"
       << "  frames: " << summary.frames << "\n"
       << "  route_length_m: " << summary.route_length << "\n"
       << "  points: " << summary.points << "\n"
       << "  odometry_mean_position_error_m: " << summary.drift.mean_position_error << "\n"
       << "  odometry_max_position_error_m: " << summary.drift.max_position_error << "\n"
       << "  odometry_final_position_error_m: " << summary.drift.final_position_error << "\n"
       << "  odometry_max_frame_translation_error_m: " << summary.drift.max_frame_translation_error << "\n"
       << "  odometry_max_frame_rotation_error_deg: " << summary.drift.max_frame_rotation_error_deg << "\n"
       << "  track_slips: " << summary.drift.slips << "\n"
       << "# Pose of the first scan in scene.ply's frame (row-major 3x4, like a poses.txt line):\n"
       << "# poses.txt and reference_map.ply are in the first scan's frame (KITTI convention).\n"
       << "world_from_first_frame: [";
  const Eigen::Isometry3d& W = sim.worldFromFirst();
  char buf[64];
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 4; ++k) {
      const double v = k < 3 ? W.linear()(r, k) : W.translation()(r);
      const auto res = std::to_chars(buf, buf + sizeof buf, v);
      info << (r || k ? ", " : "") << std::string(buf, res.ptr);
    }
  info << "]\n";
  return info.str();
}

}  // namespace

SimulationSummary writeSimulation(const SimulatorConfig& config, const fs::path& out_dir_arg,
                                  bool overwrite) {
  if (out_dir_arg.empty()) fail("simulate", "no output folder given");
  // Everything that can be wrong with the input is checked here, before anything is created.
  const Simulator sim(config);
  return writeSimulation(sim, out_dir_arg, overwrite, {});
}

SimulationSummary writeSimulation(const Simulator& sim, const fs::path& out_dir_arg, bool overwrite,
                                  const std::function<void(const fs::path& folder)>& extra) {
  const auto t_start = Clock::now();
  if (out_dir_arg.empty()) fail("simulate", "no output folder given");
  // "seq/", "./seq" and "seq" are the same folder; its name must be a real name.
  fs::path out_dir = fs::absolute(out_dir_arg).lexically_normal();
  if (!out_dir.has_filename()) out_dir = out_dir.parent_path();
  const std::string shown = out_dir_arg.string();
  const bool replace = checkSequenceOutput(out_dir, shown, overwrite);

  SimulationSummary summary;
  summary.frames = sim.frames();
  summary.route_length = sim.routeLength();
  summary.bvh_seconds = sim.bvhBuildSeconds();
  summary.drift = odometryDrift(sim.groundTruth(), sim.odometry(), sim.slips());

  TemporaryFolder tmp{temporarySibling(out_dir)};
  fs::create_directories(tmp.path);
  const ClassTable& table = sim.classTable();
  SequenceWriter writer(tmp.path, table, sim.config().sensorYaml());
  LabeledCloud reference = writeScans(sim, writer, tmp.path, summary);
  const auto t_trajectories = Clock::now();
  writeTrajectories(sim, writer, tmp.path);
  writer.finish();
  summary.write_seconds += secondsSince(t_trajectories);
  const auto t_reference = Clock::now();
  writeReferenceMap(sim, reference, tmp.path);
  reference = LabeledCloud{};
  summary.reference_seconds = secondsSince(t_reference);
  writePlyMesh(tmp.path / "scene.ply", coloredSceneMesh(sim.scene(), table));
  writeTextAtomically(tmp.path / "regions.yaml", regionsToYaml(sim.scene(), table));
  if (!sim.config().cameras.empty()) {
    const auto t_cameras = Clock::now();
    writeCameraImages(sim, sim.config().cameras, tmp.path);
    summary.camera_seconds = secondsSince(t_cameras);
  }
  writeTextAtomically(tmp.path / "simulation.yaml", simulationInfo(sim, summary));
  if (extra) extra(tmp.path);

  commitFolder(tmp, out_dir, shown, replace);
  summary.total_seconds = secondsSince(t_start);
  return summary;
}

}  // namespace hazmap::sim
