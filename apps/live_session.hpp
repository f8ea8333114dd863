#pragma once
// One `hazmap live` session (cmd_live.cpp, and `hazmap demo --live`): the sensor's UDP stream
// through the pipeline, the live view in the browser, saves on request, autosaves, and the run
// folder at the end (SIGINT, SIGTERM, or stopLiveSession()).
#include <cstdint>
#include <functional>
#include <string>

#include "config_options.hpp"
#include "live_cameras.hpp"

namespace hazmap::cli {

struct LiveOptions {
  std::string sensor;
  int port = -1;  ///< -1: the sensor's standard port
  std::string sensor_metadata, calibration, method = "property-icp+pgo", config, classes, out;
  double autosave_every = 60.0, queue_mb = 256.0;
  int threads = 0;
  bool no_deskew = false, quiet = false, no_viewer = false;
  // The live view (the page in the browser).
  bool no_view = false;
  std::string listen = "127.0.0.1:8080", token, token_file;
  double view_voxel = 0.2;
  std::size_t view_max_points = 1'000'000;
  LiveCameraOptions cameras;  ///< property cameras (none: the scans carry no property class)
};

/// Adds the live view's flags (--listen, --token, --token-file, --no-view, --view-voxel,
/// --view-max-points) to `app`.
void addLiveViewOptions(CLI::App& app, LiveOptions& o);

/// Runs the session to its end. `listening` (optional) is called once the UDP ports are bound,
/// with the data port (the demo starts its replay then).
void runLiveSession(const LiveOptions& o, const ParameterOptions& params,
                    const std::function<void(std::uint16_t)>& listening = {});
/// Ends the stream as a first SIGINT would (what the sockets hold is still decoded); thread-safe.
void stopLiveSession();

}  // namespace hazmap::cli
