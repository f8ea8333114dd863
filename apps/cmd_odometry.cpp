// hazmap odometry: LiDAR odometry over a sequence directory, a bag or a capture with
// (property-aware) ICP, the scans read as a stream.
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>

#include "command.hpp"
#include "config_options.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/preprocess/deskew.hpp"
#include "source_flags.hpp"

namespace hazmap::cli {
namespace {

struct OdometryOptions {
  std::string sequence, out, method = "property-icp", mode = "map", metric, classes, config;
  std::size_t max_frames = 0;
  int threads = 0;
  bool no_wheel = false;
  bool quiet = false;
  SourceFlags source;
};

/// One line of frames.csv and of covariances.txt.
void appendFrameRows(std::size_t i, const OdometryFrame& f, std::ostringstream& csv, std::ostringstream& cov) {
  std::string reason = f.reason;
  for (char& c : reason)
    if (c == ',' || c == '\n') c = ';';
  char line[512];  // the numbers; the reason (any length: a recovery lists every start) follows
  std::snprintf(line, sizeof line, "%zu,%.6f,%s,%d,%.4f,%.4f,%zu,%zu,%zu,%.3f,%.3f,%.3f,%d,%.3f,%d,%d,%s,%.3f,%.3f,%.3f,%d,",
                i, f.stamp, toString(f.status), f.registration.iterations, f.registration.fitness,
                f.registration.inlier_rmse, f.scan_points, f.source_points, f.map_points, f.preprocess_ms,
                f.registration_ms, f.total_ms, int(f.wheel_guess), f.registration.label_agreement,
                int(f.registration.labels_used), int(f.global.tried), f.global.tried ? toString(f.global.status) : "",
                f.global.score, f.global.second_best_score, f.global.milliseconds, int(f.global.whole_map));
  csv << line << reason << '\n';
  cov << i;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) {
      char v[32];
      std::snprintf(v, sizeof v, " %.9g", f.covariance(r, c));
      cov << v;
    }
  cov << "\n";
}

// The tracking config: the file, then the flags, then --set; validated.
OdometryConfig configOf(const OdometryOptions& o, const ParameterOptions& params) {
  OdometryConfig cfg = o.config.empty() ? OdometryConfig::defaults() : loadOdometryConfig(o.config);
  if (o.method == "icp") cfg.registration.use_classes = false;
  else if (o.method == "property-icp") cfg.registration.use_classes = true;
  else fail("--method", "expected icp or property-icp, got '" + o.method + "'");
  if (o.mode == "frame") cfg.mode = OdometryMode::FrameToFrame;
  else if (o.mode == "map") cfg.mode = OdometryMode::FrameToMap;
  else fail("--mode", "expected frame or map, got '" + o.mode + "'");
  if (o.metric == "point") cfg.registration.metric = IcpMetric::PointToPoint;
  else if (o.metric == "plane") cfg.registration.metric = IcpMetric::PointToPlane;
  else if (!o.metric.empty()) fail("--metric", "expected point or plane, got '" + o.metric + "'");
  if (o.threads < 0) fail("--threads", "must be >= 0");
  params.applySettings(cfg);
  cfg.validate();
  return cfg;
}

void run(const OdometryOptions& o, const ParameterOptions& params) {
  const OdometryConfig cfg = configOf(o, params);
  std::optional<tbb::global_control> threads;
  if (o.threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, o.threads);

  std::optional<ClassTable> table_override;
  if (!o.classes.empty()) table_override = ClassTable::load(o.classes);
  const auto scans = openScanSource(o.sequence, o.source.options(table_override, !o.quiet));
  DeskewConfig deskew;
  deskew.enabled = !o.source.no_deskew;
  StreamDeskewer deskewer(deskew);
  ImuStreamMotion imu;  // does nothing without IMU samples

  std::filesystem::create_directories(o.out);
  Odometry odo(params.propertyIcp().applyTo(scans->classTable()), cfg);
  std::ostringstream csv, cov;
  csv << "frame,stamp,status,iterations,fitness,rmse,scan_points,source_points,map_points,"
         "preprocess_ms,registration_ms,total_ms,wheel_guess,label_agreement,labels_used,global_tried,global_status,"
         "global_score,global_second_best,global_ms,global_whole_map,reason\n";
  cov << "# frame, then the 36 entries (row-major) of the increment covariance (previous <- current),"
         " translation first [x y z rx ry rz]\n";
  std::size_t fallbacks = 0, degenerate = 0, relocalised = 0, global_tried = 0;
  double total_ms = 0.0;
  std::size_t n = 0;
  bool use_wheel = false;
  std::optional<Eigen::Isometry3d> prev_wheel;
  for (std::optional<Scan> scan; (o.max_frames == 0 || n < o.max_frames) && (scan = scans->next()); ++n) {
    const std::size_t i = n;
    if (i == 0) use_wheel = scan->odometry && !o.no_wheel;
    if (use_wheel && !scan->odometry)
      fail(scans->describe(), "scan " + std::to_string(i) + " has no wheel odometry while the first had");
    std::optional<Eigen::Isometry3d> inc;
    if (use_wheel && prev_wheel) inc = prev_wheel->inverse() * *scan->odometry;
    if (use_wheel) prev_wheel = scan->odometry;
    const ImuStreamMotion::Motion imu_motion = imu.next(scan->imu, scan->stamp);
    deskewer.apply(scan->cloud, scan->stamp, inc, imu_motion.attitudePtr());
    const OdometryFrame& f = odo.addFrame(scan->cloud, inc, scan->stamp, imu_motion.rotation);
    deskewer.tracked(f.increment);
    imu.tracked(verifiedRotation(f));
    if (!o.quiet && f.status == FrameStatus::Fallback)
      std::fprintf(stderr, "frame %zu: fell back to the %s guess (flagged): %s\n", i,
                   f.wheel_guess ? "wheel-odometry" : "constant-velocity", f.reason.c_str());
    if (!o.quiet && f.status == FrameStatus::Relocalised)
      std::fprintf(stderr, "frame %zu: relocalised by global registration%s (%s)\n", i,
                   f.global.whole_map ? " against the whole map" : "", f.reason.c_str());
  }
  if (n == 0) fail(o.sequence, "has no scans");
  // The frames as they ended: a lost frame's pose is re-estimated once a later one is verified.
  for (std::size_t i = 0; i < odo.frames().size(); ++i) {
    const OdometryFrame& f = odo.frames()[i];
    fallbacks += f.status == FrameStatus::Fallback;
    degenerate += f.status == FrameStatus::Degenerate;
    relocalised += f.status == FrameStatus::Relocalised;
    global_tried += f.global.tried;
    total_ms += f.total_ms;
    appendFrameRows(i, f, csv, cov);
  }
  const Trajectory traj = odo.trajectory();
  const std::filesystem::path out(o.out);
  writeKittiTrajectory(out / "poses.txt", traj);
  writeTumTrajectory(out / "poses_tum.txt", traj);
  writeTextAtomically(out / "frames.csv", csv.str());
  writeTextAtomically(out / "covariances.txt", cov.str());
  nlohmann::json s;
  s["frames"] = n;
  s["method"] = o.method;
  s["mode"] = toString(cfg.mode);
  s["metric"] = toString(cfg.registration.metric);
  s["wheel_odometry"] = use_wheel;
  s["fallbacks"] = fallbacks;
  s["degenerate_frames"] = degenerate;
  s["relocalised_frames"] = relocalised;
  s["tracked_frames"] = n - fallbacks - relocalised;
  s["global_registrations_tried"] = global_tried;
  s["mean_ms_per_frame"] = n ? total_ms / n : 0.0;
  writeTextAtomically(out / "summary.json", s.dump(2) + "\n");
  if (!o.quiet)
    std::printf("%zu frames: %zu tracked (%zu degenerate), %zu relocalised, %zu fallback (flagged); %zu global "
                "registrations tried; %.2f ms/frame -> %s\n",
                n, n - fallbacks - relocalised, degenerate, relocalised, fallbacks, global_tried,
                n ? total_ms / n : 0.0, o.out.c_str());
}

const RegisterCommand kOdometry{{
    "odometry",
    "LiDAR odometry over a sequence directory, a bag or a capture (frame-to-frame or frame-to-local-map, property-aware "
    "ICP); writes poses.txt (KITTI), poses_tum.txt, frames.csv, covariances.txt, summary.json",
    [](CLI::App& app) {
      auto o = std::make_shared<OdometryOptions>();
      app.add_option("sequence", o->sequence,
                     "Sequence directory (velodyne/, labels/, odometry.txt, ...), bag (.bag, .mcap, rosbag2 "
                     "folder) or capture (.pcap)")
          ->required();
      app.add_option("--out", o->out, "Output directory")->required();
      app.add_option("--method", o->method, "icp | property-icp");
      app.add_option("--mode", o->mode, "frame (the paper: scan to previous scan) | map (scan to local map)");
      app.add_option("--metric", o->metric, "point | plane (default: the config's)");
      app.add_option("--config", o->config, "Odometry settings (YAML, see docs/registration.md)");
      app.add_option("--classes", o->classes, "Class table overriding the sequence's: default, semantic-kitti or YAML");
      app.add_option("--max-frames", o->max_frames, "Process only the first N frames (0 = all)");
      app.add_option("--threads", o->threads, "Worker threads (0 = all)");
      app.add_flag("--no-wheel", o->no_wheel, "Ignore odometry.txt / the odometry topic (constant-velocity guess)");
      o->source.add(app);
      app.add_flag("--quiet", o->quiet, "No progress output");
      auto params = addParameterOptions(app, "keys of the odometry section, e.g. registration.max_iterations=30");
      app.callback([o, params] { run(*o, *params); });
    }}};

}  // namespace
}  // namespace hazmap::cli
