// hazmap run INPUT --method M --out DIR: the whole SLAM run and its outputs. INPUT is a sequence
// folder, a bag (ROS 1, rosbag2, MCAP) or a packet capture, read as a stream.
#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "command.hpp"
#include "config_options.hpp"
#include "hazmap/pipeline/progress.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "source_flags.hpp"

namespace hazmap::cli {
namespace {

struct RunOptions {
  std::string sequence;
  std::string method = "property-icp+pgo";
  std::string out;
  std::string config;
  std::string classes;
  int threads = 0;
  bool quiet = false;
  SourceFlags source;
};

void run(const RunOptions& o, const ParameterOptions& params) {
  const SlamMethod method = parseSlamMethod(o.method);
  SlamConfig config = SlamConfig::forMethod(method);
  if (!o.config.empty()) config.applyYamlFile(o.config);
  // Parameter flags (config_options.hpp) override the file.
  config.property_icp = params.propertyIcp(config.property_icp);
  params.applySettings(config);
  config.threads = o.threads;
  std::optional<ClassTable> table;
  if (!o.classes.empty()) table = ClassTable::load(o.classes);
  config.deskew.enabled = !o.source.no_deskew;
  const auto scans = openScanSource(o.sequence, o.source.options(table, !o.quiet));
  ProgressBar bar(o.method, scans->size().value_or(0), o.quiet ? 0 : -1);
  const SlamResult result = runSlam(*scans, config, [&](std::size_t d, std::size_t) { bar.update(d); });
  bar.finish();
  // The map is a second pass over the recording with the final poses.
  const auto second_pass = openScanSource(o.sequence, o.source.options(table));
  const RunSummary summary = writeRunOutputs(*second_pass, result, config, OutputConfig{}, o.out);
  if (o.quiet) return;
  std::cout << fmt::format("{}: {} frames, {:.1f} frames/s, {} loops accepted, {} hazards, map {} cells\n",
                           o.method, result.frames.size(), result.framesPerSecond(), result.loops.size(),
                           summary.hazards, summary.map_cells);
  if (summary.map_error)
    std::cout << fmt::format("map error vs true-pose map: mean {:.3f} m, median {:.3f} m, p95 {:.3f} m\n",
                             summary.map_error->point.mean, summary.map_error->point.median,
                             summary.map_error->point.p95);
  if (summary.trajectory)
    std::cout << fmt::format("ATE (SE(3)-aligned) rmse {:.3f} m\n", summary.trajectory->ape.translation.rmse);
  std::cout << "wrote " << o.out << "/ (trajectory.kitti/.tum, graph.g2o, map.ply/.pcd, hazards.json/.csv, "
               "map_top.png, trajectory.png, run.json)\n";
}

const RegisterCommand registration{{
    "run",
    "Run SLAM on a sequence directory, a bag or a packet capture and write trajectory, graph, map, "
    "hazards, PNGs and run.json",
    [](CLI::App& app) {
      auto o = std::make_shared<RunOptions>();
      app.add_option("sequence", o->sequence,
                     "Sequence directory (velodyne/, labels/, odometry.txt, ...), bag (.bag, .mcap, rosbag2 "
                     "folder) or capture (.pcap)")
          ->required();
      app.add_option("--method", o->method,
                     "odometry | icp | icp+pgo | property-icp | property-icp+pgo (the paper's Table 2 rows)");
      app.add_option("--out", o->out, "Output folder (created if missing)")->required();
      app.add_option("--config", o->config,
                     "YAML with sections odometry:, loop_closure:, graph:, slam:, wheel_noise: "
                     "(overrides the method's defaults)");
      app.add_option("--classes", o->classes,
                     "Class table: 'default', 'semantic-kitti' or a YAML file (overrides hazmap.yaml)");
      app.add_option("--threads", o->threads, "Worker threads (0 = all cores)");
      app.add_flag("--quiet", o->quiet, "No progress bar and no summary");
      o->source.add(app);
      auto params = addParameterOptions(app, "keys as in --config, e.g. odometry.registration.max_iterations=30");
      app.callback([o, params] { run(*o, *params); });
    }}};

}  // namespace
}  // namespace hazmap::cli
