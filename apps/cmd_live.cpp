// hazmap live --sensor velodyne|ouster|hesai [--port N] --out DIR: SLAM on a LiDAR's UDP stream,
// through the same decoders and pipeline as `hazmap run`, into the same run folder. SIGINT or
// SIGTERM ends the run and writes the folder (a second signal aborts at once); an autosave every
// --autosave-every seconds bounds what a kill -9 loses.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <csignal>
#include <iostream>
#include <memory>
#include <unistd.h>

#include "command.hpp"
#include "config_options.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "hazmap/sources/live_source.hpp"

namespace hazmap::cli {
namespace {

struct LiveOptions {
  std::string sensor;
  int port = -1;  ///< -1: the sensor's standard port
  std::string sensor_metadata, calibration, method = "property-icp+pgo", config, classes, out;
  double autosave_every = 60.0, queue_mb = 256.0;
  int threads = 0;
  bool no_deskew = false, quiet = false, no_viewer = false;
};

std::atomic<bool> g_stop{false};
volatile std::sig_atomic_t g_signal = 0;

/// First SIGINT/SIGTERM: end the stream (the run folder is written); a second: abort now.
extern "C" void onSignal(int signal) {
  if (g_stop.load()) ::_exit(128 + signal);
  g_signal = signal;
  g_stop.store(true);
}

void installSignalHandlers() {
  struct sigaction action {};
  action.sa_handler = onSignal;
  sigemptyset(&action.sa_mask);
  ::sigaction(SIGINT, &action, nullptr);
  ::sigaction(SIGTERM, &action, nullptr);
}

SlamConfig liveConfig(const LiveOptions& o, const ParameterOptions& params) {
  SlamConfig config = SlamConfig::forMethod(parseSlamMethod(o.method));
  if (!o.config.empty()) config.applyYamlFile(o.config);
  config.property_icp = params.propertyIcp(config.property_icp);
  params.applySettings(config);
  config.threads = o.threads;
  config.deskew.enabled = !o.no_deskew;
  return config;
}

ScanSourceOptions sourceOptions(const LiveOptions& o, LiveSensor sensor) {
  ScanSourceOptions s;
  s.sensor_metadata = o.sensor_metadata;
  if (sensor == LiveSensor::Velodyne) s.velodyne_calibration = o.calibration;
  if (sensor == LiveSensor::Hesai) s.hesai_calibration = o.calibration;
  // A model name (VLP-16, Pandar64) is passed on: packets of another model are then counted.
  const std::string family = toString(sensor);
  const bool named_family = std::equal(o.sensor.begin(), o.sensor.end(), family.begin(), family.end(),
                                       [](char a, char b) { return std::tolower(static_cast<unsigned char>(a)) == b; });
  if (!named_family) s.sensor = o.sensor;
  if (!o.classes.empty()) s.class_table = ClassTable::load(o.classes);
  s.notice = [](const std::string& line) { std::cerr << "notice: " << line << "\n"; };
  return s;
}

nlohmann::json liveJson(const LiveScanSource& source, LiveSensor sensor, bool final_write) {
  const LiveStats s = source.stats();
  const char* stopped = g_signal == SIGTERM ? "SIGTERM" : g_signal == SIGINT ? "SIGINT" : "end of stream";
  return {{"sensor", toString(sensor)}, {"data_port", source.dataPort()},
          {"auxiliary_port", source.auxiliaryPort()}, {"received", s.receiver.received},
          {"kernel_dropped", s.receiver.kernel_dropped}, {"queue_dropped", s.receiver.queue_dropped},
          {"truncated", s.receiver.truncated}, {"lost", s.lost}, {"scans_skipped", s.scans_skipped},
          {"silences", s.silences}, {"decoder", s.decoder}, {"spool", "live.pcap"},
          {"state", final_write ? std::string("stopped by ") + stopped : std::string("autosave while running")}};
}

/// The run folder from `result` (the end's or an autosave's): the map's second pass re-reads the
/// spool; run.json gains the stream's counts (`live`).
void writeLiveRun(LiveScanSource& source, const SlamResult& result, const SlamConfig& config,
                  const LiveOptions& o, LiveSensor sensor, bool final_write) {
  source.flushSpool();
  const std::filesystem::path out(o.out);
  ScanSourceOptions options = sourceOptions(o, sensor);
  options.notice = nullptr;  // the live pass said it already
  const auto second_pass = openLiveSpool(out / "live.pcap", sensor, options);
  OutputConfig outputs;
  outputs.write_viewer = !o.no_viewer;
  outputs.write_map_folder = final_write;  // the reopenable map once, at the end (not every autosave)
  const RunSummary summary = writeRunOutputs(*second_pass, result, config, outputs, out);
  nlohmann::json j = nlohmann::json::parse(readTextFile(out / "run.json"));
  j["live"] = liveJson(source, sensor, final_write);
  writeTextAtomically(out / "run.json", j.dump(2) + "\n");
  if (o.quiet) return;
  if (final_write) std::cout << formatRunSummary(result, summary, out, outputs);
  else std::cout << fmt::format("autosaved {} frames to {}\n", result.frames.size(), o.out) << std::flush;
}

void live(const LiveOptions& o, const ParameterOptions& params) {
  const LiveSensor sensor = liveSensorNamed(o.sensor);
  if (o.port < -1 || o.port > 65535) fail("--port", std::to_string(o.port) + " is no UDP port (0-65535)");
  if (!(o.queue_mb >= 0.01 && o.queue_mb <= 65536)) fail("--queue-mb", "must be in [0.01, 65536] MiB");
  if (!(o.autosave_every >= 0)) fail("--autosave-every", "must be >= 0 seconds (0: no autosave)");
  const SlamConfig config = liveConfig(o, params);
  config.validate();
  const std::filesystem::path out(o.out);
  std::filesystem::create_directories(out);
  LiveSourceOptions live;
  live.sensor = sensor;
  if (o.port >= 0) live.port = static_cast<std::uint16_t>(o.port);
  live.spool = out / "live.pcap";
  live.stop = &g_stop;
  live.queue_bytes = static_cast<std::size_t>(o.queue_mb * 1024 * 1024);
  const auto source = openLiveSource(live, sourceOptions(o, sensor));
  if (!o.sensor_metadata.empty())  // beside the spool, so `hazmap run DIR/live.pcap` finds it
    std::filesystem::copy_file(o.sensor_metadata, out / "live.json", std::filesystem::copy_options::overwrite_existing);
  installSignalHandlers();
  std::cout << fmt::format("listening on UDP port {} ({}; auxiliary port {}); Ctrl-C ends the run and writes {}\n",
                           source->dataPort(), toString(sensor), source->auxiliaryPort(), o.out)
            << std::flush;
  auto last_save = std::chrono::steady_clock::now();
  SlamSnapshots autosave;
  autosave.due = [&] {
    return o.autosave_every > 0 &&
           std::chrono::duration<double>(std::chrono::steady_clock::now() - last_save).count() >= o.autosave_every;
  };
  autosave.take = [&](const SlamResult& snapshot) {
    try {
      writeLiveRun(*source, snapshot, config, o, sensor, false);
    } catch (const Error& e) {
      std::cerr << "notice: autosave failed: " << e.what() << "\n";
    }
    last_save = std::chrono::steady_clock::now();
  };
  const SlamResult result = runSlam(*source, config, {}, autosave);
  writeLiveRun(*source, result, config, o, sensor, true);
}

const RegisterCommand registration{{
    "live",
    "SLAM on a LiDAR's live UDP stream (Velodyne, Ouster, Hesai); Ctrl-C writes the same run folder as "
    "hazmap run",
    [](CLI::App& app) {
      auto o = std::make_shared<LiveOptions>();
      app.add_option("--sensor", o->sensor, "velodyne | ouster | hesai, or a model name (VLP-16, Pandar64, ...)")
          ->required();
      app.add_option("--port", o->port,
                     "UDP data port (default: the sensor's, 2368 or Ouster's 7502; the auxiliary port is then "
                     "the sensor's too, else this + 1)");
      app.add_option("--sensor-metadata", o->sensor_metadata, "Ouster metadata JSON (required for Ouster)");
      app.add_option("--calibration", o->calibration,
                     "Velodyne calibration YAML or Hesai angle-correction CSV (default: the model's own)");
      app.add_option("--method", o->method,
                     "odometry | icp | icp+pgo | property-icp | property-icp+pgo (as hazmap run)");
      app.add_option("--config", o->config, "YAML of settings (as hazmap run --config)");
      app.add_option("--classes", o->classes, "Class table: 'default', 'semantic-kitti' or a YAML file");
      app.add_option("--out", o->out, "Output folder (created if missing)")->required();
      app.add_option("--autosave-every", o->autosave_every,
                     "Write the run folder every this many seconds while running (0: never)");
      app.add_option("--queue-mb", o->queue_mb,
                     "Datagrams waiting for the decoder, at most (MiB): beyond it they are dropped and counted");
      app.add_option("--threads", o->threads, "Worker threads (0 = all cores)");
      app.add_flag("--no-deskew", o->no_deskew, "Do not motion-compensate scans with per-point times");
      app.add_flag("--no-viewer", o->no_viewer, "Do not write viewer.html");
      app.add_flag("--quiet", o->quiet, "No summary (the listening line is still printed)");
      auto params = addParameterOptions(app, "keys as in --config, e.g. odometry.registration.max_iterations=30");
      app.callback([o, params] { live(*o, *params); });
    }}};

}  // namespace
}  // namespace hazmap::cli
