#pragma once
// `hazmap replay --camera CAM.yaml`: a recorded camera's images (its folder of 16-bit PNGs and
// times.txt, as `hazmap simulate --cameras` writes them) sent as RTP (rtpgstpay over UDP, see
// sources/gst_camera.hpp) alongside the capture's datagrams, each at its own stamp on the
// capture's clock, so `hazmap live --camera CAM.yaml --camera-pipeline "$(GstFrameSender::
// receiverPipeline(port))"` labels the scans as `hazmap run CAPTURE --camera CAM.yaml` does.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/properties/camera.hpp"
#include "hazmap/properties/property_image.hpp"
#include "hazmap/sources/gst_camera.hpp"

namespace hazmap::cli {

class ReplayCameras {
 public:
  /// Camera k's images go to `host`:`first_port` + k. Throws hazmap::Error naming the YAML (or its
  /// image folder) when it cannot be read.
  ReplayCameras(const std::vector<std::string>& yamls, const std::string& host, int first_port);
  /// The earliest image's time (ns on the capture's clock); nullopt without images.
  std::optional<std::int64_t> firstTime() const;
  /// Sends, in time order, every image not yet sent stamped at or before `until_ns` (all with
  /// nullopt), calling `pace(t)` before each (it sleeps until t's turn).
  void sendUntil(std::optional<std::int64_t> until_ns, const std::function<void(std::int64_t)>& pace);
  void rewind() { next_ = 0; }  ///< --loop: from the first image again
  std::uint64_t sent() const { return sent_; }
  std::size_t count() const { return cameras_.size(); }

 private:
  struct Camera {
    CameraCalibration calibration;
    std::unique_ptr<ImageFolder> folder;
    std::unique_ptr<GstFrameSender> sender;
  };
  struct Image {
    std::int64_t time_ns;
    std::size_t camera, index;
  };
  std::vector<Camera> cameras_;
  std::vector<Image> images_;  // sorted by time
  std::size_t next_ = 0;
  std::uint64_t sent_ = 0;
};

}  // namespace hazmap::cli
