#pragma once
// `hazmap live --camera CAM.yaml --camera-pipeline '… ! appsink'` (issue 33, part 2): each camera's
// GStreamer pipeline feeding its ring of frames, and the labeler the live scans go through.
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "hazmap/properties/live_camera.hpp"
#include "hazmap/sources/gst_camera.hpp"

namespace hazmap::cli {

struct LiveCameraOptions {
  std::vector<std::string> cameras, pipelines;  ///< one pipeline per camera, in order
  std::string rules;                            ///< empty: the built-in rules of the channels
  double wait = 0.5, ring_mb = 256.0;
};

class LiveCameras {
 public:
  /// Reads the calibrations and the rules, starts the pipelines. Throws hazmap::Error (one line:
  /// a camera without its pipeline, a rig file, a pipeline that does not parse or start).
  LiveCameras(const LiveCameraOptions& o, const ClassTable& table);
  ~LiveCameras();
  LiveLabeler& labeler() { return *labeler_; }
  /// Channel → the cameras giving it (run outputs, as `hazmap run --camera` has them).
  const std::map<std::string, std::vector<std::string>>& channelCameras() const { return channel_cameras_; }
  std::vector<LiveCameraStats> stats() const;
  nlohmann::json json() const;  ///< run.json's live.cameras

 private:
  std::vector<std::shared_ptr<LiveCamera>> cameras_;
  std::vector<std::unique_ptr<GstFrameReceiver>> receivers_;
  std::unique_ptr<LiveLabeler> labeler_;
  std::map<std::string, std::vector<std::string>> channel_cameras_;
};

/// Adds --camera, --camera-pipeline, --rules, --camera-wait, --camera-ring-mb to `app`.
void addLiveCameraOptions(CLI::App& app, LiveCameraOptions& o);

}  // namespace hazmap::cli
