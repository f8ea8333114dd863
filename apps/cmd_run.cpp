// hazmap run SEQ --method M --out DIR: the whole SLAM run and its outputs.
#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "command.hpp"
#include "hazmap/pipeline/progress.hpp"
#include "hazmap/pipeline/run_outputs.hpp"

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
  bool no_viewer = false;
};

void run(const RunOptions& o) {
  const SlamMethod method = parseSlamMethod(o.method);
  SlamConfig config = SlamConfig::forMethod(method);
  if (!o.config.empty()) config.applyYamlFile(o.config);
  config.threads = o.threads;
  std::optional<ClassTable> table;
  if (!o.classes.empty()) table = ClassTable::load(o.classes);
  const Sequence sequence = Sequence::open(o.sequence, table);
  ProgressBar bar(o.method, sequence.size(), o.quiet ? 0 : -1);
  const SlamResult result = runSlam(sequence, config, [&](std::size_t d, std::size_t) { bar.update(d); });
  bar.finish();
  OutputConfig outputs;
  outputs.write_viewer = !o.no_viewer;
  const RunSummary summary = writeRunOutputs(sequence, result, config, outputs, o.out);
  if (o.quiet) return;
  std::cout << formatRunSummary(result, summary, o.out, outputs);
}

const RegisterCommand registration{{
    "run",
    "Run SLAM on a sequence directory and write trajectory, graph, map, hazards, PNGs and run.json",
    [](CLI::App& app) {
      auto o = std::make_shared<RunOptions>();
      app.add_option("sequence", o->sequence, "Sequence directory (velodyne/, labels/, odometry.txt, ...)")
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
      app.add_flag("--no-viewer", o->no_viewer, "Do not write viewer.html (the map in 3D in a browser)");
      app.callback([o] { run(*o); });
    }}};

}  // namespace
}  // namespace hazmap::cli
