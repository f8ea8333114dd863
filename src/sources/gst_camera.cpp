// GStreamer pipelines for camera frames (gst_camera.hpp): appsink → CameraFrame on a thread of
// its own, and CameraFrame bytes → appsrc → rtpgstpay → udpsink for `hazmap replay`.
#include "hazmap/sources/gst_camera.hpp"

#include <fmt/format.h>
#include <gst/app/gstappsink.h>
#include <gst/app/gstappsrc.h>
#include <gst/gst.h>
#include <gst/video/video.h>

#include <atomic>
#include <condition_variable>
#include <cstring>
#include <ctime>
#include <mutex>
#include <optional>
#include <thread>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {

void initGstreamer(const std::string& where) {
  static std::once_flag once;
  static std::string failure;
  std::call_once(once, [] {
    GError* error = nullptr;
    if (!gst_init_check(nullptr, nullptr, &error)) {
      failure = error ? error->message : "gst_init failed";
      g_clear_error(&error);
    }
  });
  if (!failure.empty()) fail(where, "cannot start GStreamer: " + failure);
}

std::string oneLine(std::string text) {
  for (char& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  return text;
}

/// An error posted on the bus as one line: GStreamer's message and, when it adds something, its
/// debug text's last part (which names the element and the cause).
std::string busError(GstMessage* message) {
  GError* error = nullptr;
  gchar* debug = nullptr;
  gst_message_parse_error(message, &error, &debug);
  std::string text = error ? error->message : "unknown error";
  const std::string source = GST_MESSAGE_SRC(message) ? GST_OBJECT_NAME(GST_MESSAGE_SRC(message)) : "";
  if (!source.empty()) text = source + ": " + text;
  g_clear_error(&error);
  g_free(debug);
  return oneLine(text);
}

std::int64_t realtimeNs() {
  timespec now;
  ::clock_gettime(CLOCK_REALTIME, &now);
  return std::int64_t{now.tv_sec} * 1'000'000'000 + now.tv_nsec;
}

struct FormatName {
  const char* gst;
  const char* encoding;
  int bytes;  // per pixel
  bool big_endian;
};
constexpr FormatName kFormats[] = {{"GRAY8", "mono8", 1, false},    {"GRAY16_LE", "mono16", 2, false},
                                   {"GRAY16_BE", "mono16", 2, true}, {"RGB", "rgb8", 3, false},
                                   {"BGR", "bgr8", 3, false},        {"RGBA", "rgba8", 4, false},
                                   {"BGRA", "bgra8", 4, false}};

GstElement* findAppSink(GstElement* pipeline) {
  if (GST_IS_APP_SINK(pipeline)) return pipeline;
  if (!GST_IS_BIN(pipeline)) return nullptr;
  GstIterator* it = gst_bin_iterate_recurse(GST_BIN(pipeline));
  GValue item = G_VALUE_INIT;
  GstElement* found = nullptr;
  while (!found && gst_iterator_next(it, &item) == GST_ITERATOR_OK) {
    auto* element = GST_ELEMENT(g_value_get_object(&item));
    if (GST_IS_APP_SINK(element)) found = element;
    g_value_reset(&item);
  }
  g_value_unset(&item);
  gst_iterator_free(it);
  return found;
}

/// The sample as a frame, or the reason it is none.
std::optional<CameraFrame> frameOf(GstSample* sample, GstClockTime base_time, std::string& why) {
  GstCaps* caps = gst_sample_get_caps(sample);
  GstBuffer* buffer = gst_sample_get_buffer(sample);
  GstVideoInfo info;
  if (!caps || !buffer) return why = "a sample without caps or buffer", std::nullopt;
  if (!gst_video_info_from_caps(&info, caps)) {
    gchar* text = gst_caps_to_string(caps);
    why = std::string("caps are not raw video: ") + text;
    g_free(text);
    return std::nullopt;
  }
  const std::string format = gst_video_format_to_string(GST_VIDEO_INFO_FORMAT(&info));
  const FormatName* f = nullptr;
  for (const auto& k : kFormats)
    if (format == k.gst) f = &k;
  if (!f)
    return why = "video format " + format + " is not supported (" + acceptedCameraFormats() +
                 "; convert with `videoconvert ! video/x-raw,format=GRAY16_LE` or `format=GRAY8`)",
           std::nullopt;
  CameraFrame frame;
  frame.width = GST_VIDEO_INFO_WIDTH(&info);
  frame.height = GST_VIDEO_INFO_HEIGHT(&info);
  std::size_t stride = GST_VIDEO_INFO_PLANE_STRIDE(&info, 0), offset = GST_VIDEO_INFO_PLANE_OFFSET(&info, 0);
  if (const GstVideoMeta* meta = gst_buffer_get_video_meta(buffer)) stride = meta->stride[0], offset = meta->offset[0];
  frame.encoding = f->encoding;
  frame.big_endian = f->big_endian;
  frame.step = static_cast<std::uint32_t>(frame.width * f->bytes);
  GstMapInfo map;
  if (!gst_buffer_map(buffer, &map, GST_MAP_READ)) return why = "cannot read a buffer", std::nullopt;
  const std::size_t need = frame.height == 0 ? 0 : offset + stride * (frame.height - 1) + frame.step;
  if (frame.width <= 0 || frame.height <= 0 || map.size < need) {
    why = fmt::format("a {}x{} {} buffer of {} bytes (needs {})", frame.width, frame.height, format, map.size, need);
    gst_buffer_unmap(buffer, &map);
    return std::nullopt;
  }
  frame.data.resize(static_cast<std::size_t>(frame.step) * frame.height);
  for (int y = 0; y < frame.height; ++y)
    std::memcpy(frame.data.data() + static_cast<std::size_t>(y) * frame.step, map.data + offset + stride * y, frame.step);
  gst_buffer_unmap(buffer, &map);
  const GstSegment* segment = gst_sample_get_segment(sample);
  const GstClockTime pts = GST_BUFFER_PTS(buffer);
  const GstClockTime running =
      GST_CLOCK_TIME_IS_VALID(pts) && segment ? gst_segment_to_running_time(segment, GST_FORMAT_TIME, pts) : GST_CLOCK_TIME_NONE;
  frame.time_ns = GST_CLOCK_TIME_IS_VALID(running) && GST_CLOCK_TIME_IS_VALID(base_time)
                      ? static_cast<std::int64_t>(base_time + running)
                      : realtimeNs();  // no time stamp: when it reached the sink
  return frame;
}

}  // namespace

const char* acceptedCameraFormats() { return "GRAY8, GRAY16_LE, GRAY16_BE, RGB, BGR, RGBA, BGRA"; }

struct GstFrameReceiver::Impl {
  std::string where;
  Sink sink;
  Notice notice;
  GstElement* pipeline = nullptr;
  GstAppSink* appsink = nullptr;
  GstBus* bus = nullptr;
  std::atomic<bool> stop{false};
  std::thread thread;
  mutable std::mutex m;
  GstReceiverStats stats;
  std::string told;  // the last line given to notice (each is told once)

  void tell(const std::string& line, bool error) {
    {
      std::lock_guard<std::mutex> lock(m);
      if (error) stats.last_error = line;
      if (line == told) return;
      told = line;
    }
    if (notice) notice(where + ": " + line);
  }
  void run();
  bool pollBus();
  void restart();
};

/// Drains the bus; true when the pipeline stopped (an error or the end of its stream).
bool GstFrameReceiver::Impl::pollBus() {
  bool stopped = false;
  while (GstMessage* message = gst_bus_pop(bus)) {
    if (GST_MESSAGE_TYPE(message) == GST_MESSAGE_ERROR) {
      {
        std::lock_guard<std::mutex> lock(m);
        ++stats.pipeline_errors;
      }
      tell(busError(message), true);
      stopped = true;
    } else if (GST_MESSAGE_TYPE(message) == GST_MESSAGE_EOS) {
      tell("the stream ended", true);
      stopped = true;
    }
    gst_message_unref(message);
  }
  return stopped || gst_app_sink_is_eos(appsink);
}

/// After an error: stopped, then started again every second until it runs (or the receiver ends).
void GstFrameReceiver::Impl::restart() {
  gst_element_set_state(pipeline, GST_STATE_NULL);
  for (int i = 0; i < 10 && !stop; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  if (stop) return;
  {
    std::lock_guard<std::mutex> lock(m);
    ++stats.restarts;
  }
  gst_element_set_state(pipeline, GST_STATE_PLAYING);
}

void GstFrameReceiver::Impl::run() {
  bool failed = false;
  while (!stop) {
    if (GstSample* sample = gst_app_sink_try_pull_sample(appsink, 100 * GST_MSECOND)) {
      std::string why;
      std::optional<CameraFrame> frame = frameOf(sample, gst_element_get_base_time(pipeline), why);
      gst_sample_unref(sample);
      if (!frame) {
        {
          std::lock_guard<std::mutex> lock(m);
          ++stats.rejected;
        }
        tell(why, true);
        continue;
      }
      {
        std::lock_guard<std::mutex> lock(m);
        ++stats.frames;
      }
      if (failed) tell("frames again", false), failed = false;
      sink(std::move(*frame));
    }
    if (pollBus()) {
      failed = true;
      restart();
    }
  }
}

GstFrameReceiver::GstFrameReceiver(const std::string& description, const std::string& where, Sink sink, Notice notice)
    : impl_(std::make_unique<Impl>()) {
  initGstreamer(where);
  Impl& s = *impl_;
  s.where = where;
  s.sink = std::move(sink);
  s.notice = std::move(notice);
  GError* error = nullptr;
  GstElement* parsed = gst_parse_launch(description.c_str(), &error);
  if (error || !parsed) {
    const std::string text = error ? error->message : "cannot parse";
    g_clear_error(&error);
    if (parsed) gst_object_unref(parsed);
    fail(where, "the pipeline does not parse: " + oneLine(text));
  }
  if (!GST_IS_PIPELINE(parsed)) {  // a single element: wrapped so it has a bus and a clock
    s.pipeline = gst_pipeline_new(nullptr);
    gst_bin_add(GST_BIN(s.pipeline), parsed);
  } else {
    s.pipeline = parsed;
  }
  GstElement* appsink = findAppSink(s.pipeline);
  if (!appsink) {
    gst_object_unref(s.pipeline);
    fail(where, "the pipeline has no appsink (end it with `! appsink name=camera`)");
  }
  s.appsink = GST_APP_SINK(appsink);
  gst_app_sink_set_max_buffers(s.appsink, 8);  // a slow reader loses old frames, never stalls the camera
  gst_app_sink_set_drop(s.appsink, TRUE);
  // The realtime clock: base time + running time is then a CLOCK_REALTIME instant (see the header).
  GstClock* clock = GST_CLOCK(g_object_new(GST_TYPE_SYSTEM_CLOCK, "clock-type", GST_CLOCK_TYPE_REALTIME, nullptr));
  gst_pipeline_use_clock(GST_PIPELINE(s.pipeline), clock);
  gst_object_unref(clock);
  s.bus = gst_element_get_bus(s.pipeline);
  // What fails while starting (a missing device, an unreadable file, a port in use) says so now;
  // a live source that fails later (an RTSP camera not answering) is counted and retried.
  if (gst_element_set_state(s.pipeline, GST_STATE_PLAYING) == GST_STATE_CHANGE_FAILURE ||
      gst_element_get_state(s.pipeline, nullptr, nullptr, GST_SECOND) == GST_STATE_CHANGE_FAILURE) {
    std::string why = "the pipeline does not start";
    if (GstMessage* message = gst_bus_pop_filtered(s.bus, GST_MESSAGE_ERROR)) {
      why = busError(message);
      gst_message_unref(message);
    }
    gst_element_set_state(s.pipeline, GST_STATE_NULL);
    gst_object_unref(s.bus);
    gst_object_unref(s.pipeline);
    fail(where, why);
  }
  s.thread = std::thread([&s] { s.run(); });
}

GstFrameReceiver::~GstFrameReceiver() {
  impl_->stop = true;
  if (impl_->thread.joinable()) impl_->thread.join();
  gst_element_set_state(impl_->pipeline, GST_STATE_NULL);
  gst_object_unref(impl_->bus);
  gst_object_unref(impl_->pipeline);
}

GstReceiverStats GstFrameReceiver::stats() const {
  std::lock_guard<std::mutex> lock(impl_->m);
  return impl_->stats;
}

struct GstFrameSender::Impl {
  std::string where, caps;
  GstElement* pipeline = nullptr;
  GstAppSrc* src = nullptr;
};

GstFrameSender::GstFrameSender(const std::string& host, int port, const std::string& where)
    : impl_(std::make_unique<Impl>()) {
  initGstreamer(where);
  impl_->where = where;
  const std::string description = fmt::format(
      "appsrc name=src format=time is-live=true block=true max-bytes=67108864 ! rtpgstpay config-interval=1 ! "
      "udpsink host={} port={} sync=false async=false",
      host, port);
  GError* error = nullptr;
  impl_->pipeline = gst_parse_launch(description.c_str(), &error);
  if (error || !impl_->pipeline) {
    const std::string text = error ? error->message : "cannot parse";
    g_clear_error(&error);
    if (impl_->pipeline) gst_object_unref(impl_->pipeline);
    fail(where, "cannot build the RTP sender (" + oneLine(text) + "; is gstreamer1.0-plugins-good installed?)");
  }
  impl_->src = GST_APP_SRC(gst_bin_get_by_name(GST_BIN(impl_->pipeline), "src"));
  if (gst_element_set_state(impl_->pipeline, GST_STATE_PLAYING) == GST_STATE_CHANGE_FAILURE) {
    gst_object_unref(impl_->src);
    gst_object_unref(impl_->pipeline);
    fail(where, fmt::format("cannot send RTP to {}:{}", host, port));
  }
}

GstFrameSender::~GstFrameSender() {
  gst_app_src_end_of_stream(impl_->src);
  // What is queued leaves before the pipeline stops (at most 2 s).
  GstBus* bus = gst_element_get_bus(impl_->pipeline);
  if (GstMessage* m = gst_bus_timed_pop_filtered(bus, 2 * GST_SECOND,
                                                 static_cast<GstMessageType>(GST_MESSAGE_EOS | GST_MESSAGE_ERROR)))
    gst_message_unref(m);
  gst_object_unref(bus);
  gst_element_set_state(impl_->pipeline, GST_STATE_NULL);
  gst_object_unref(impl_->src);
  gst_object_unref(impl_->pipeline);
}

void GstFrameSender::send(int width, int height, const std::string& gst_format, std::span<const std::uint8_t> data,
                          std::int64_t pts_ns) {
  const std::string caps = fmt::format("video/x-raw,format={},width={},height={},framerate=0/1", gst_format, width, height);
  if (caps != impl_->caps) {
    GstCaps* c = gst_caps_from_string(caps.c_str());
    gst_app_src_set_caps(impl_->src, c);
    gst_caps_unref(c);
    impl_->caps = caps;
  }
  GstBuffer* buffer = gst_buffer_new_allocate(nullptr, data.size(), nullptr);
  gst_buffer_fill(buffer, 0, data.data(), data.size());
  GST_BUFFER_PTS(buffer) = static_cast<GstClockTime>(std::max<std::int64_t>(0, pts_ns));
  if (gst_app_src_push_buffer(impl_->src, buffer) != GST_FLOW_OK)  // takes the buffer
    fail(impl_->where, "the RTP sender stopped");
}

std::string GstFrameSender::receiverPipeline(int port, const std::string& appsink_name) {
  return fmt::format(
      "udpsrc port={} buffer-size=16777216 caps=\"application/x-rtp,media=application,clock-rate=90000,"
      "encoding-name=X-GST\" ! rtpgstdepay ! appsink name={}",
      port, appsink_name);
}

}  // namespace hazmap
