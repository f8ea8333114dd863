// Live property cameras: the ring of recent frames, and each scan labelled from the frames nearest
// to it (live_camera.hpp).
#include "hazmap/properties/live_camera.hpp"

#include <algorithm>
#include <chrono>
#include <ctime>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {

std::int64_t nowNs() {
  timespec now;
  ::clock_gettime(CLOCK_REALTIME, &now);
  return std::int64_t{now.tv_sec} * 1'000'000'000 + now.tv_nsec;
}

/// The ring's frames at the moment of a scan: stamps and images shared with the ring.
class RingImages final : public ImageSource {
 public:
  void add(double stamp, std::shared_ptr<const PropertyImage> image) {
    stamps_.push_back(stamp);
    images_.push_back(std::move(image));
  }
  const std::vector<double>& stamps() const override { return stamps_; }
  PropertyImage load(std::size_t i, const CameraCalibration&) const override { return *images_.at(i); }

 private:
  std::vector<double> stamps_;
  std::vector<std::shared_ptr<const PropertyImage>> images_;
};

std::size_t bytesOf(const PropertyImage& image) { return image.values.size() * sizeof(float); }

}  // namespace

double realtimeSeconds(std::int64_t time_ns) {  // as PcapReader converts a record's time
  return static_cast<double>(time_ns / 1'000'000'000) + static_cast<double>(time_ns % 1'000'000'000) * 1e-9;
}

LiveCamera::LiveCamera(CameraCalibration camera, LiveCameraConfig config)
    : camera_(std::move(camera)), config_(config) {
  stats_.name = camera_.name;
}

bool LiveCamera::push(const CameraFrame& frame) {
  ImageMsg msg;
  msg.header.stamp = realtimeSeconds(frame.time_ns);
  msg.width = static_cast<std::uint32_t>(frame.width);
  msg.height = static_cast<std::uint32_t>(frame.height);
  msg.encoding = frame.encoding;
  msg.is_bigendian = frame.big_endian;
  msg.step = frame.step;
  msg.data = frame.data;
  std::shared_ptr<const PropertyImage> image;
  try {
    image = std::make_shared<const PropertyImage>(imageFromMessage(msg, camera_, camera_.name));
  } catch (const Error& e) {
    std::lock_guard<std::mutex> lock(m_);
    ++stats_.rejected;
    stats_.last_error = e.what();
    return false;
  }
  {
    std::lock_guard<std::mutex> lock(m_);
    // A frame older than the newest (a clock step, a reordered stream) is kept in order.
    const auto at = std::upper_bound(ring_.begin(), ring_.end(), image->stamp,
                                     [](double t, const Kept& k) { return t < k.stamp; });
    ring_.insert(at, Kept{image->stamp, image});
    ring_bytes_ += bytesOf(*image);
    while (ring_bytes_ > config_.ring_bytes && ring_.size() > 1) {
      ring_bytes_ -= bytesOf(*ring_.front().image);
      ring_.erase(ring_.begin());
      ++stats_.ring_dropped;
    }
    ++stats_.frames;
    last_frame_ns_ = std::max(last_frame_ns_, nowNs());
    stats_.stalled = false;
  }
  arrived_.notify_all();
  return true;
}

void LiveCamera::waitFor(double t, std::int64_t deadline_ns) const {
  std::unique_lock<std::mutex> lock(m_);
  const auto reached = [&] { return !ring_.empty() && ring_.back().stamp >= t; };
  // A camera silent for longer than `stall` (or not heard yet) is not waited for: tracking would
  // otherwise lag behind the sensor by the whole wait for as long as it stays silent.
  const auto silent = [&] { return last_frame_ns_ == 0 || double(nowNs() - last_frame_ns_) * 1e-9 > config_.stall; };
  while (!reached() && !silent()) {
    const std::int64_t left = deadline_ns - nowNs();
    if (left <= 0) return;
    arrived_.wait_for(lock, std::chrono::nanoseconds(std::min<std::int64_t>(left, 50'000'000)));
  }
}

std::shared_ptr<const ImageSource> LiveCamera::snapshot() const {
  auto images = std::make_shared<RingImages>();
  std::lock_guard<std::mutex> lock(m_);
  for (const Kept& k : ring_) images->add(k.stamp, k.image);
  return images;
}

void LiveCamera::release(double t) {
  std::lock_guard<std::mutex> lock(m_);
  // Frame i goes when frame i + 1 is not later than t: for any later scan it is strictly nearer.
  std::size_t drop = 0;
  while (drop + 1 < ring_.size() && ring_[drop + 1].stamp <= t && ring_[drop].stamp < ring_[drop + 1].stamp) ++drop;
  for (std::size_t k = 0; k < drop; ++k) ring_bytes_ -= bytesOf(*ring_[k].image);
  ring_.erase(ring_.begin(), ring_.begin() + static_cast<std::ptrdiff_t>(drop));
}

void LiveCamera::countMissing() {
  std::lock_guard<std::mutex> lock(m_);
  ++stats_.scans_without_image;
}

void LiveCamera::setPipelineStats(std::uint64_t errors, std::uint64_t restarts, const std::string& last_error) {
  std::lock_guard<std::mutex> lock(m_);
  stats_.pipeline_errors = errors;
  stats_.restarts = restarts;
  if (!last_error.empty()) stats_.last_error = last_error;
}

LiveCameraStats LiveCamera::stats() const {
  std::lock_guard<std::mutex> lock(m_);
  LiveCameraStats s = stats_;
  if (last_frame_ns_ > 0) s.last_frame_age_s = std::max(0.0, double(nowNs() - last_frame_ns_) * 1e-9);
  const bool stalled = !s.last_frame_age_s || *s.last_frame_age_s > config_.stall;
  if (stalled && !stats_.stalled && s.last_frame_age_s) ++stats_.stalls;
  stats_.stalled = stalled;
  s.stalled = stalled;
  s.stalls = stats_.stalls;
  return s;
}

LiveLabeler::LiveLabeler(std::vector<std::shared_ptr<LiveCamera>> cameras, PropertyRules rules, LabelerConfig config,
                         LiveCameraConfig live)
    : cameras_(std::move(cameras)), rules_(std::move(rules)), config_(config), live_(live) {
  if (cameras_.empty()) fail("--camera", "no camera given");
  config_.validate("labeler");
  for (const auto& c : cameras_) {
    const std::string& name = c->calibration().channel.name;
    if (std::find(channels_.begin(), channels_.end(), name) == channels_.end()) channels_.push_back(name);
    else config_.footprints = true;  // several cameras on a channel: the nearest view wins, as in `hazmap label`
  }
  rules_.checkChannels(channels_, "rules");
}

ScanLabels LiveLabeler::label(const LabeledCloud& scan, double time) {
  std::vector<CameraInput> inputs;
  for (const auto& c : cameras_) {
    const CameraCalibration& cal = c->calibration();
    const double t = time - cal.time_offset;
    const double deadline = t + config_.time_tolerance + live_.wait;
    c->waitFor(t, static_cast<std::int64_t>(deadline * 1e9));
    inputs.push_back({cal, c->snapshot()});
  }
  const PropertyLabeler labeler(std::move(inputs), rules_, config_);
  ScanLabels labels = labeler.label(scan, time);
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    if (labels.image_index[k] < 0) cameras_[k]->countMissing();
    cameras_[k]->release(time - cameras_[k]->calibration().time_offset);
  }
  return labels;
}

}  // namespace hazmap
