// The live property cameras of `hazmap live` (live_cameras.hpp).
#include "live_cameras.hpp"

#include <iostream>

#include "hazmap/core/error.hpp"
#include "hazmap/pipeline/live_view_messages.hpp"
#include "hazmap/properties/camera_rig.hpp"
#include "hazmap/properties/label_sequence.hpp"

namespace hazmap::cli {

void addLiveCameraOptions(CLI::App& app, LiveCameraOptions& o) {
  app.add_option("--camera", o.cameras,
                 "Label the scans from this calibrated camera (camera.yaml, as hazmap label; repeatable, each with its "
                 "--camera-pipeline)");
  app.add_option("--camera-pipeline", o.pipelines,
                 "The camera's frames: a gst-launch description ending in appsink (GRAY8, GRAY16_LE, RGB, ...; "
                 "README 'Live on the robot'); one per --camera, in order");
  app.add_option("--rules", o.rules, "Class rules YAML for --camera (default: built-in rules)");
  app.add_option("--camera-wait", o.wait,
                 "Seconds a scan waits, past its time and the time tolerance, for a camera frame still on its way");
  app.add_option("--camera-ring-mb", o.ring_mb, "Frames kept per camera waiting for their scans, at most (MiB)");
}

LiveCameras::LiveCameras(const LiveCameraOptions& o, const ClassTable& table) {
  if (o.pipelines.size() != o.cameras.size())
    fail("--camera-pipeline", "give one per --camera (" + std::to_string(o.cameras.size()) + " cameras, " +
                                  std::to_string(o.pipelines.size()) + " pipelines)");
  if (!(o.wait >= 0 && o.wait <= 60)) fail("--camera-wait", "must be in [0, 60] s");
  if (!(o.ring_mb >= 1 && o.ring_mb <= 65536)) fail("--camera-ring-mb", "must be in [1, 65536] MiB");
  std::vector<std::filesystem::path> files(o.cameras.begin(), o.cameras.end());
  if (expandCameraFiles(files).size() != files.size())
    fail("--camera", "a camera rig needs one pipeline per camera: give each camera.yaml with its --camera-pipeline");
  LiveCameraConfig config;
  config.wait = o.wait;
  config.ring_bytes = static_cast<std::size_t>(o.ring_mb * 1024 * 1024);
  std::vector<std::string> channels;
  for (const auto& file : files) {
    cameras_.push_back(std::make_shared<LiveCamera>(readCameraYaml(file), config));
    const CameraCalibration& c = cameras_.back()->calibration();
    channels.push_back(c.channel.name);
    channel_cameras_[c.channel.name].push_back(c.name);
  }
  labeler_ = std::make_unique<LiveLabeler>(cameras_, cameraRules(o.rules, channels, table), LabelerConfig{}, config);
  for (std::size_t k = 0; k < files.size(); ++k) {
    std::shared_ptr<LiveCamera> camera = cameras_[k];
    const std::string where = "--camera-pipeline of " + camera->calibration().name;
    receivers_.push_back(std::make_unique<GstFrameReceiver>(
        o.pipelines[k], where,
        [camera, where](CameraFrame&& frame) {
          if (!camera->push(frame) && camera->stats().rejected == 1)  // said once; counted in /status
            std::cerr << "notice: " << where << ": " << camera->stats().last_error << "\n";
        },
        [](const std::string& line) { std::cerr << "notice: " << line << "\n"; }));
  }
}

LiveCameras::~LiveCameras() { receivers_.clear(); }  // their threads end before the cameras go

std::vector<LiveCameraStats> LiveCameras::stats() const {
  std::vector<LiveCameraStats> out;
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    if (k < receivers_.size()) {
      const GstReceiverStats r = receivers_[k]->stats();
      cameras_[k]->setPipelineStats(r.pipeline_errors, r.restarts, r.last_error);
      LiveCameraStats s = cameras_[k]->stats();
      s.rejected += r.rejected;  // samples the pipeline could not turn into frames
      out.push_back(std::move(s));
    } else {
      out.push_back(cameras_[k]->stats());
    }
  }
  return out;
}

nlohmann::json LiveCameras::json() const { return nlohmann::json::parse(liveCamerasJson(stats())); }

}  // namespace hazmap::cli
