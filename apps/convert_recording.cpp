// hazmap convert BAG_OR_CAPTURE OUT_DIR: a recording as a sequence folder.
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <iostream>
#include <random>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/imu.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/io/trajectory.hpp"
#include "recording.hpp"

namespace hazmap::cli {

namespace {

namespace fs = std::filesystem;

/// A folder next to the destination that is removed unless renamed into place.
class StagingFolder {
 public:
  explicit StagingFolder(const fs::path& destination) : destination_(fs::absolute(destination).lexically_normal()) {
    if (!destination_.has_filename()) destination_ = destination_.parent_path();
    std::error_code ec;
    if (fs::exists(destination_, ec) && !(fs::is_directory(destination_, ec) && fs::is_empty(destination_, ec)))
      fail(destination.string(), "exists and is not an empty folder");
    std::random_device rd;
    path_ = destination_.parent_path() / ("." + destination_.filename().string() + ".partial-" +
                                          std::to_string(rd() % 1000000));
    fs::create_directories(path_ / "velodyne", ec);
    if (ec) fail(path_.string(), "cannot create: " + ec.message());
  }
  ~StagingFolder() {
    std::error_code ec;
    if (!committed_) fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }
  void commit() {
    std::error_code ec;
    fs::remove(destination_, ec);  // an empty folder, checked above
    fs::rename(path_, destination_, ec);
    if (ec) fail(destination_.string(), "cannot move the converted sequence into place: " + ec.message());
    committed_ = true;
  }

 private:
  fs::path destination_, path_;
  bool committed_ = false;
};

std::string frameName(std::size_t i) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%06zu", i);
  return buf;
}

}  // namespace

void convertRecording(const fs::path& input, const fs::path& out_dir, const SourceFlags& flags, bool quiet) {
  const auto scans = openScanSource(input, flags.options(std::nullopt, !quiet));
  StagingFolder staging(out_dir);
  std::ostringstream times;
  times.precision(17);
  Trajectory odometry, truth;
  bool with_odometry = true, with_truth = true;
  std::size_t n = 0, points = 0;
  // The IMU stream again, from the scans' spans (each from the previous scan's stamp, one sample
  // beyond each end: they overlap): a folder run, or `label`/`run --camera` (which convert first),
  // then deskews, guesses and gets gravity as a run on the recording does.
  std::vector<ImuSample> imu;
  for (std::optional<Scan> scan; (scan = scans->next()); ++n) {
    for (const ImuSample& sample : scan->imu)
      if (imu.empty() || sample.time > imu.back().time) imu.push_back(sample);
    // Per-point times stay in the PCD (absolute seconds), so a run on the folder deskews as a
    // run on the recording does.
    writePcd(staging.path() / "velodyne" / (frameName(n) + ".pcd"), scan->cloud, PcdEncoding::Binary);
    points += scan->cloud.size();
    times << scan->stamp << "\n";
    with_odometry = with_odometry && scan->odometry;
    with_truth = with_truth && scan->ground_truth;
    if (with_odometry) odometry.push_back(scan->stamp, *scan->odometry);
    if (with_truth) truth.push_back(scan->stamp, *scan->ground_truth);
  }
  if (n == 0) fail(input.string(), "has no LiDAR scans to convert");
  writeTextAtomically(staging.path() / "times.txt", times.str());
  if (with_odometry) writeKittiTrajectory(staging.path() / "odometry.txt", odometry);
  if (with_truth) writeKittiTrajectory(staging.path() / "poses.txt", truth);
  if (!imu.empty()) writeImuFile(staging.path() / "imu.txt", imu);
  YAML::Emitter yaml;
  yaml << YAML::Comment("hazmap sequence converted from " + input.string());
  yaml << YAML::BeginMap << YAML::Key << "frames" << YAML::Value << n;
  yaml << YAML::Key << "source" << YAML::Value << scans->describe();
  yaml << YAML::Key << "class_table" << YAML::Value << YAML::Load(scans->classTable().toYamlString());
  yaml << YAML::EndMap;
  writeTextAtomically(staging.path() / "hazmap.yaml", std::string(yaml.c_str()) + "\n");
  staging.commit();
  if (!quiet)
    std::cout << fmt::format("{} -> {}: {} scans, {} points{}{}{}\n", scans->describe(), out_dir.string(), n, points,
                             with_odometry ? ", odometry.txt" : "", with_truth ? ", poses.txt" : "",
                             imu.empty() ? "" : fmt::format(", imu.txt ({} samples)", imu.size()));
}

}  // namespace hazmap::cli
