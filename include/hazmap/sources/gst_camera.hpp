#pragma once
// A camera's frames through a GStreamer pipeline (issue 33, part 2): `hazmap live --camera-pipeline
// '… ! appsink'` receives them (a UVC core on v4l2src, an RTSP camera, RTP over UDP), `hazmap
// replay --camera` sends recorded ones as RTP (rtpgstpay over UDP). Raw frames only: turning
// pixels into a channel's values is the properties stage's (live_camera.hpp).
//
// Time: the receiving pipeline runs on a CLOCK_REALTIME system clock, so a buffer's running time
// (its PTS through the sample's segment) plus the pipeline's base time is the CLOCK_REALTIME
// instant the source stamped it (v4l2src: the driver's capture time; udpsrc: the datagram's
// arrival) — the clock of the LiDAR datagrams' kernel receive stamps (SO_TIMESTAMPNS).
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

namespace hazmap {

/// One raw frame as a camera delivered it.
struct CameraFrame {
  std::int64_t time_ns = 0;   ///< CLOCK_REALTIME of the buffer's PTS (ns since the epoch)
  int width = 0, height = 0;
  std::string encoding;       ///< sensor_msgs/Image names: mono8, mono16, rgb8, bgr8, rgba8, bgra8
  bool big_endian = false;    ///< mono16 only (GRAY16_BE)
  std::uint32_t step = 0;     ///< bytes per row (rows may be padded)
  std::vector<std::uint8_t> data;
};

/// The video/x-raw formats accepted, and the encodings they become.
const char* acceptedCameraFormats();

struct GstReceiverStats {
  std::uint64_t frames = 0;           ///< frames delivered
  std::uint64_t rejected = 0;         ///< samples without usable caps or in an unsupported format
  std::uint64_t pipeline_errors = 0;  ///< errors the pipeline posted (each followed by a restart)
  std::uint64_t restarts = 0;
  std::string last_error;             ///< the newest error or rejection, one line
};

/// Runs a `gst-launch` description that contains an appsink; a thread pulls its samples.
class GstFrameReceiver {
 public:
  using Sink = std::function<void(CameraFrame&&)>;
  using Notice = std::function<void(const std::string&)>;
  /// Parses and starts `description`. Throws hazmap::Error naming `where` for a description that
  /// does not parse (GStreamer's message), one without an appsink, or a pipeline that fails to
  /// start. Later errors (a camera unplugged, a stream ending) are counted and told to `notice`
  /// once each, and the pipeline is restarted every second until it runs again.
  GstFrameReceiver(const std::string& description, const std::string& where, Sink sink, Notice notice = {});
  ~GstFrameReceiver();
  GstFrameReceiver(const GstFrameReceiver&) = delete;
  GstFrameReceiver& operator=(const GstFrameReceiver&) = delete;
  GstReceiverStats stats() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

/// Sends raw frames as RTP over UDP: appsrc ! rtpgstpay ! udpsink. rtpgstpay carries the buffer
/// and its caps unchanged (the caps again every second), so 16-bit grey keeps every count;
/// RTP raw video (RFC 4175, rtpvrawpay) has no grey formats.
class GstFrameSender {
 public:
  /// Throws hazmap::Error naming `where` when the pipeline cannot start (a missing plug-in).
  GstFrameSender(const std::string& host, int port, const std::string& where);
  ~GstFrameSender();
  GstFrameSender(const GstFrameSender&) = delete;
  GstFrameSender& operator=(const GstFrameSender&) = delete;
  /// One frame of `gst_format` (GRAY16_LE, GRAY8, RGB) with tightly packed rows, `pts_ns` after
  /// the first frame's.
  void send(int width, int height, const std::string& gst_format, std::span<const std::uint8_t> data,
            std::int64_t pts_ns);
  /// Receiver pipeline for this transport: `udpsrc port=… ! rtpgstdepay ! appsink`.
  static std::string receiverPipeline(int port, const std::string& appsink_name = "camera");

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace hazmap
