// hazmap live --sensor velodyne|ouster|hesai [--port N] --out DIR: SLAM on a LiDAR's UDP stream,
// through the same decoders and pipeline as `hazmap run`, into the same run folder, with the live
// view in the browser (--listen, default 127.0.0.1:8080). SIGINT or SIGTERM ends the run and
// writes the folder (a second signal aborts at once); an autosave every --autosave-every seconds
// bounds what a kill -9 loses; POST /save (the page's button) writes it on request.
#include <memory>

#include "command.hpp"
#include "config_options.hpp"
#include "live_session.hpp"

namespace hazmap::cli {
namespace {

const RegisterCommand registration{{
    "live",
    "SLAM on a LiDAR's live UDP stream (Velodyne, Ouster, Hesai) with the live view in the browser; Ctrl-C "
    "writes the same run folder as hazmap run",
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
                     "Write the run folder while running, this many seconds after the last save ended (0: never)");
      app.add_option("--queue-mb", o->queue_mb,
                     "Datagrams waiting for the decoder, at most (MiB): beyond it they are dropped and counted");
      app.add_option("--threads", o->threads, "Worker threads (0 = all cores)");
      app.add_flag("--no-deskew", o->no_deskew, "Do not motion-compensate scans with per-point times");
      app.add_flag("--no-viewer", o->no_viewer, "Do not write viewer.html");
      app.add_flag("--quiet", o->quiet, "No summary (the listening line is still printed)");
      addLiveViewOptions(app, *o);
      addLiveCameraOptions(app, o->cameras);
      auto params = addParameterOptions(app, "keys as in --config, e.g. odometry.registration.max_iterations=30");
      app.callback([o, params] { runLiveSession(*o, *params); });
    }}};

}  // namespace
}  // namespace hazmap::cli
