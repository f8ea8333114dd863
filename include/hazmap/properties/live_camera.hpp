#pragma once
// Live property cameras (issue 33, part 2): each camera's recent frames in a ring, and the
// labelling of each live scan from them with the same projection and rules as `hazmap label`.
//
// Frames come from anything that calls LiveCamera::push (a GstFrameReceiver in `hazmap live`, a
// test directly), stamped on CLOCK_REALTIME, the clock of the live LiDAR scans. A scan taken at
// t uses, per camera, the frame nearest to t − time_offset within the labeler's time tolerance
// (the rule of PropertyLabeler); it waits for that frame until CLOCK_REALTIME reaches
// t − time_offset + tolerance + wait, unless the camera is stalled (no frame for `stall` s, or none
// yet): then no scan waits for it. A scan labelled late finds its frames still kept.
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/properties/labeler.hpp"
#include "hazmap/sources/gst_camera.hpp"

namespace hazmap {

struct LiveCameraConfig {
  double wait = 0.5;        ///< s a scan waits, past its time + tolerance, for a frame still on its way
  double stall = 1.0;       ///< s without a frame: the camera counts as stalled
  std::size_t ring_bytes = std::size_t(256) << 20;  ///< converted frames kept per camera, at most
};

struct LiveCameraStats {
  std::string name;
  std::uint64_t frames = 0;             ///< frames kept
  std::uint64_t rejected = 0;           ///< frames that could not be used (size, encoding), see last_error
  std::uint64_t ring_dropped = 0;       ///< frames dropped unused because the ring was full
  std::uint64_t scans_without_image = 0;  ///< scans this camera had no frame for within the tolerance
  std::uint64_t stalls = 0;             ///< times it went silent for longer than `stall`
  std::optional<double> last_frame_age_s;
  bool stalled = false;
  std::string last_error;
  // The pipeline's own counts (GstFrameReceiver), when one feeds the camera.
  std::uint64_t pipeline_errors = 0, restarts = 0;
};

class LiveCamera {
 public:
  LiveCamera(CameraCalibration camera, LiveCameraConfig config = {});
  const CameraCalibration& calibration() const { return camera_; }
  /// A frame from the camera (any thread): converted to the channel's values as a bag's
  /// sensor_msgs/Image is (imageFromMessage) and kept; one that cannot be (another size than the
  /// calibration's, an unknown encoding) is counted, its reason kept. Returns false then.
  bool push(const CameraFrame& frame);
  /// Waits until a frame stamped at or after `t` (camera clock, s) is kept or CLOCK_REALTIME
  /// reaches `deadline_ns`; not at all while the camera is stalled.
  void waitFor(double t, std::int64_t deadline_ns) const;
  /// The kept frames as an image source (shared, not copied).
  std::shared_ptr<const ImageSource> snapshot() const;
  /// Scans up to camera time `t` are labelled: frames no later scan can pick are let go.
  void release(double t);
  void countMissing();
  /// The pipeline's counts and newest error are reported with the camera's.
  void setPipelineStats(std::uint64_t errors, std::uint64_t restarts, const std::string& last_error);
  LiveCameraStats stats() const;

 private:
  struct Kept {
    double stamp;
    std::shared_ptr<const PropertyImage> image;
  };
  CameraCalibration camera_;
  LiveCameraConfig config_;
  mutable std::mutex m_;
  mutable std::condition_variable arrived_;
  std::vector<Kept> ring_;
  std::size_t ring_bytes_ = 0;
  mutable LiveCameraStats stats_;  // stalls are counted when the status is read
  std::int64_t last_frame_ns_ = 0;
};

/// Labels live scans from live cameras (thread-safe per call; calls in scan order).
class LiveLabeler {
 public:
  /// `rules` over the cameras' channels (PropertyRules::checkChannels is run).
  LiveLabeler(std::vector<std::shared_ptr<LiveCamera>> cameras, PropertyRules rules, LabelerConfig config,
              LiveCameraConfig live = {});
  /// The channel names in label order (as PropertyLabeler::channels()).
  const std::vector<std::string>& channels() const { return channels_; }
  const std::vector<std::shared_ptr<LiveCamera>>& cameras() const { return cameras_; }
  /// Labels one scan taken at `time` (CLOCK_REALTIME, s), waiting for late frames as said above.
  ScanLabels label(const LabeledCloud& scan, double time);

 private:
  std::vector<std::shared_ptr<LiveCamera>> cameras_;
  PropertyRules rules_;
  LabelerConfig config_;
  LiveCameraConfig live_;
  std::vector<std::string> channels_;
};

/// The seconds of a CLOCK_REALTIME nanosecond stamp, converted as the live LiDAR's are.
double realtimeSeconds(std::int64_t time_ns);

}  // namespace hazmap
