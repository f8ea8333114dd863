#include "hazmap/pipeline/live_view_feed.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include "hazmap/map/render.hpp"
#include "hazmap/map/viewer.hpp"
#include "pipeline/live_view_queue.hpp"

namespace hazmap {

namespace {

using SteadyClock = std::chrono::steady_clock;

using pipeline_detail::LiveViewItem;

std::vector<Eigen::Vector3d> translations(const std::vector<Eigen::Isometry3d>& poses) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(poses.size());
  for (const auto& pose : poses) out.push_back(pose.translation());
  return out;
}

/// The calling thread yields to every other (nice 19): on a machine whose cores are all busy,
/// tracking and the receive thread come first, the view waits.
void lowestPriority() { ::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), 19); }

double secondsSince(SteadyClock::time_point t) { return std::chrono::duration<double>(SteadyClock::now() - t).count(); }

std::string pageHtml(const LiveViewFeedConfig& config, const ClassTable& classes) {
  ViewerScene scene;
  scene.title = config.title;
  scene.source = "live";
  scene.classes = classes;
  scene.trajectories.push_back({"estimate", {}, {208, 64, 255}});
  ViewerConfig viewer;
  viewer.live = true;
  viewer.three_dir = config.three_dir;
  return viewerHtml(scene, viewer);
}

/// Per frame put into the view's hazard map: the pose it was inserted at, and its newest.
using PropertyPoses = std::map<std::size_t, std::pair<Eigen::Isometry3d, Eigen::Isometry3d>>;

/// The hazards moved as the frames that saw them moved since they went into the hazard map (the
/// middle frame of a hazard's first range stands for it): the map keeps its cells where they
/// were inserted, the page draws each hazard where the corrected poses put it (its box shifted
/// with its centroid, its values unchanged).
std::vector<Hazard> movedHazards(std::vector<Hazard> hazards, const PropertyPoses& poses) {
  for (Hazard& h : hazards) {
    if (h.frames.empty()) continue;
    auto it = poses.upper_bound((std::size_t{h.frames[0].first} + h.frames[0].last) / 2);
    if (it == poses.begin()) continue;
    --it;
    const Eigen::Vector3d centroid = it->second.second * (it->second.first.inverse() * h.centroid);
    const Eigen::Vector3d shift = centroid - h.centroid;
    h.centroid = centroid;
    h.min += shift;
    h.max += shift;
  }
  return hazards;
}

}  // namespace

struct LiveViewFeed::Impl {
  LiveViewFeedConfig config;
  ClassTable classes;
  std::function<UdpReceiverStats()> receiver;
  LiveMapVoxels voxels;
  GlobalMap hazard_map;
  bool hazards_dirty = false;
  SteadyClock::time_point hazards_found{};
  std::size_t corrections_seen = 0;  // pipeline thread only
  PropertyPoses property_poses;      // the view's thread only, as the two below
  std::vector<Hazard> live_hazards;  // as found on hazard_map (not moved)

  mutable std::mutex m;  // everything below
  std::condition_variable wake, idle;
  pipeline_detail::LiveViewQueue queue;
  bool busy = false, stop = false;
  std::vector<std::string> map_messages;  // every map message so far: a new browser's snapshot
  std::vector<Eigen::Vector3d> positions;
  std::string pose_message, hazards_message, status_message;
  std::string anchors_message;  // every map segment's pose, as of the last correction
  bool hazards_saved = false;   // the page shows a save's hazards (until the live ones change)
  LiveStatus counts;  // the status line's own fields (frames, hazards, tracking, map_points, saves, …)
  std::optional<std::chrono::steady_clock::time_point> last_save_taken;  // the last complete save's snapshot
  std::deque<SteadyClock::time_point> frame_times;  // the last 2 s: frames/s
  RecentLatency recent_latency;                      // the last 600 frames
  std::string state_override;

  std::unique_ptr<LiveViewServer> server;  // last: its threads call back into the members above
  std::thread worker;

  Impl(LiveViewFeedConfig c, ClassTable t)
      : config(std::move(c)), classes(std::move(t)), voxels(classes, config.map), hazard_map(config.hazard_map, classes),
        queue(config.queue_bytes) {}

  void run();
  void process(LiveViewItem& item);
  void reanchor(const std::vector<Eigen::Isometry3d>& poses);
  void findHazards();
  void publishStatus();
  LiveStatus status() const;
  std::vector<std::string> snapshot() const;
};

void LiveViewFeed::Impl::run() {
  lowestPriority();
  for (;;) {
    std::deque<LiveViewItem> batch;
    {
      std::unique_lock<std::mutex> lock(m);
      wake.wait_for(lock, std::chrono::milliseconds(250), [&] { return stop || !queue.empty(); });
      if (stop && queue.empty()) return;
      batch = queue.take();
      busy = !batch.empty();
    }
    for (LiveViewItem& item : batch) process(item);
    findHazards();
    publishStatus();
    {
      std::lock_guard<std::mutex> lock(m);
      for (const LiveViewItem& item : batch) queue.release(item.bytes);
      busy = false;
    }
    idle.notify_all();
  }
}

void LiveViewFeed::Impl::process(LiveViewItem& item) {
  if (item.correction) reanchor(item.corrected);
  if (!item.has_frame) return;
  if (item.scan) {
    for (std::string& message : voxels.add(item.frame, *item.scan, item.pose)) {
      {
        std::lock_guard<std::mutex> lock(m);
        map_messages.push_back(message);
        counts.map_points = voxels.points();
      }
      server->publish(std::move(message));  // a browser joining in between drops the repeat (seq)
    }
    const auto& c = item.scan->classes;
    if (std::any_of(c.begin(), c.end(), [&](ClassId id) { return classes.isProperty(id); })) {
      hazard_map.insert(item.frame, *item.scan, item.pose);
      property_poses[item.frame] = {item.pose, item.pose};
      hazards_dirty = true;
    }
  }
  const Eigen::Vector3d p = item.pose.translation();
  std::string pose;
  {
    std::lock_guard<std::mutex> lock(m);
    if (positions.size() <= item.frame) positions.resize(item.frame + 1, p);
    positions[item.frame] = p;
    pose = pose_message = livePoseMessage(item.frame, item.pose, item.status);
    counts.tracking = toString(item.status);
  }
  if (!item.correction) server->publish(liveTrackMessage(item.frame, p));  // else: in the redrawn trajectory
  server->publishState("pose", std::move(pose));
}

// Corrected poses: the trajectory takes them, the map's segments that moved follow (the state for
// new browsers first, then the update: one joining in between gets both, which is harmless).
void LiveViewFeed::Impl::reanchor(const std::vector<Eigen::Isometry3d>& poses) {
  std::string moved = voxels.reanchor(poses), trajectory, hazards;
  for (auto& [frame, inserted_and_now] : property_poses)
    if (frame < poses.size()) inserted_and_now.second = poses[frame];
  if (!live_hazards.empty()) hazards = liveHazardsMessage(movedHazards(live_hazards, property_poses), classes, "live");
  {
    std::lock_guard<std::mutex> lock(m);
    const std::vector<Eigen::Vector3d> corrected = translations(poses);
    if (corrected.size() >= positions.size()) positions = corrected;
    else std::copy(corrected.begin(), corrected.end(), positions.begin());
    trajectory = liveTrajectoryMessage(positions);
    if (!moved.empty()) anchors_message = voxels.anchorsMessage();
    if (!moved.empty()) ++counts.map_corrections;
    if (hazards_saved) hazards.clear();  // the page shows a save's: keep them
    if (!hazards.empty()) hazards_message = hazards;
  }
  if (!hazards.empty()) server->publishState("hazards", std::move(hazards));
  if (!moved.empty()) server->publish(std::move(moved));
  server->publishState("trajectory", std::move(trajectory));
}

void LiveViewFeed::Impl::findHazards() {
  if (!hazards_dirty || secondsSince(hazards_found) < config.hazards_every) return;
  hazards_dirty = false;
  hazards_found = SteadyClock::now();
  live_hazards = hazmap::findHazards(hazard_map, config.hazards);
  std::string message = liveHazardsMessage(movedHazards(live_hazards, property_poses), classes, "live");
  {
    std::lock_guard<std::mutex> lock(m);
    hazards_message = message;
    hazards_saved = false;
    counts.hazards = live_hazards.size();
  }
  server->publishState("hazards", std::move(message));
}

LiveStatus LiveViewFeed::Impl::status() const {
  LiveStatus s;
  {
    std::lock_guard<std::mutex> lock(m);
    s = counts;
    if (frame_times.size() >= 2)
      s.frames_per_s = double(frame_times.size() - 1) /
                       std::max(1e-3, std::chrono::duration<double>(frame_times.back() - frame_times.front()).count());
    s.state = state_override;
    if (const auto l = recent_latency.summary(); l.frames > 0) s.latency_ms = l;
    if (last_save_taken)
      s.last_save_age_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - *last_save_taken).count();
  }
  std::optional<UdpReceiverStats> r;
  if (receiver) r = receiver();
  if (r) {
    s.packets = r->received;
    s.drops = r->kernel_dropped + r->queue_dropped + r->truncated;
    s.queue_datagrams = r->queued;
    s.queue_bytes = r->queued_bytes;
    if (r->last_received_ns > 0) {
      timespec now;
      ::clock_gettime(CLOCK_REALTIME, &now);
      const std::int64_t ns = std::int64_t{now.tv_sec} * 1'000'000'000 + now.tv_nsec - r->last_received_ns;
      s.last_packet_age_s = std::max(0.0, double(ns) * 1e-9);
    }
  }
  if (config.cameras) s.cameras = config.cameras();
  for (const LiveCameraStats& c : s.cameras)
    s.camera_warnings += c.rejected + c.pipeline_errors + c.ring_dropped + c.stalls + c.scans_without_image;
  if (server) {
    const LiveViewStats v = server->stats();
    s.clients = v.clients;
    s.clients_dropped = v.clients_dropped;
  }
  const bool silent = r && (!s.last_packet_age_s || *s.last_packet_age_s > config.silence_seconds);
  if (s.state.empty()) s.state = silent ? "waiting for sensor" : s.frames == 0 ? "starting" : "tracking";
  if (silent) s.frames_per_s = 0;
  return s;
}

void LiveViewFeed::Impl::publishStatus() {
  const LiveStatus s = status();
  std::string message = liveStatusMessage(s);
  {
    std::lock_guard<std::mutex> lock(m);
    status_message = message;
  }
  server->setStatus(liveStatusJson(s));
  server->publishState("status", std::move(message));
}

// Ready-made messages only: the server holds its lock while a browser's snapshot is taken.
std::vector<std::string> LiveViewFeed::Impl::snapshot() const {
  std::lock_guard<std::mutex> lock(m);
  std::vector<std::string> out = map_messages;
  if (!anchors_message.empty()) out.push_back(anchors_message);  // after the map: it moves what they drew
  out.push_back(liveTrajectoryMessage(positions));
  for (const std::string* s : {&hazards_message, &pose_message, &status_message})
    if (!s->empty()) out.push_back(*s);
  return out;
}

LiveViewFeed::LiveViewFeed(LiveViewFeedConfig config, ClassTable classes, std::function<UdpReceiverStats()> receiver,
                           LiveViewServer::SaveHandler on_save)
    : impl_(std::make_unique<Impl>(std::move(config), std::move(classes))) {
  Impl& s = *impl_;
  s.receiver = std::move(receiver);
  const std::string page = pageHtml(s.config, s.classes);  // before listening: three.js missing is an error
  s.server = std::make_unique<LiveViewServer>(s.config.server, std::move(on_save), [&s] { return s.snapshot(); });
  s.server->addFile("/", "text/html; charset=utf-8", page);
  s.server->addFile("/index.html", "text/html; charset=utf-8", page);
  s.publishStatus();
  s.worker = std::thread([&s] { s.run(); });
}

LiveViewFeed::~LiveViewFeed() {
  {
    std::lock_guard<std::mutex> lock(impl_->m);
    impl_->stop = true;
  }
  impl_->wake.notify_all();
  if (impl_->worker.joinable()) impl_->worker.join();
  impl_->server.reset();  // closes the browsers before the members they read go
}

int LiveViewFeed::port() const { return impl_->server->port(); }

void LiveViewFeed::onFrame(const SlamFrameEvent& event, std::optional<double> latency_s) {
  Impl& s = *impl_;
  LiveViewItem item;
  item.frame = event.record.index;
  item.pose = event.poses.back();
  item.status = event.record.status;
  if (event.corrections != s.corrections_seen) {
    s.corrections_seen = event.corrections;
    item.correction = true;
    item.corrected = event.poses;
  }
  const std::size_t bytes = pipeline_detail::scanBytes(event.scan);
  bool room = false;
  {
    std::lock_guard<std::mutex> lock(s.m);
    ++s.counts.frames;
    s.counts.back_end_backlog = event.back_end_backlog;
    if (latency_s) s.recent_latency.add(*latency_s);
    s.frame_times.push_back(SteadyClock::now());
    while (s.frame_times.size() > 2 && secondsSince(s.frame_times.front()) > 2.0) s.frame_times.pop_front();
    room = s.queue.reserve(bytes);
    if (!room) ++s.counts.view_frames_skipped;
  }
  if (room) {
    item.scan = std::make_unique<LabeledCloud>(event.scan);  // the copy, outside the lock
    item.bytes = bytes;
  }
  {
    std::lock_guard<std::mutex> lock(s.m);
    s.queue.push(std::move(item));
  }
  s.wake.notify_one();
}

void LiveViewFeed::setState(const std::string& state) {
  {
    std::lock_guard<std::mutex> lock(impl_->m);
    impl_->state_override = state;
  }
  impl_->wake.notify_one();
  impl_->publishStatus();
}

void LiveViewFeed::showSaved(const std::vector<Hazard>& hazards, const Trajectory& trajectory, const std::string& where,
                             std::optional<SaveTiming> timing) {
  Impl& s = *impl_;
  std::string message = liveHazardsMessage(hazards, s.classes, "saved");
  {
    std::lock_guard<std::mutex> lock(s.m);
    s.hazards_message = message;
    s.hazards_saved = true;
    s.counts.hazards = hazards.size();
    ++s.counts.saves;
    s.counts.last_save = where;
    if (timing) {
      s.counts.last_save_frames = timing->frames;
      s.counts.last_save_seconds = timing->seconds;
      s.last_save_taken = timing->taken;
    }
  }
  s.server->publishState("hazards", std::move(message));
  if (!trajectory.poses.empty()) {  // the saved estimate: the view's thread redraws the trajectory and moves the map
    LiveViewItem item;
    item.has_frame = false;
    item.correction = true;
    item.corrected.assign(trajectory.poses.begin(), trajectory.poses.end());
    {
      std::lock_guard<std::mutex> lock(s.m);
      s.queue.push(std::move(item));
    }
    s.wake.notify_one();
  }
  s.publishStatus();
}

void LiveViewFeed::showSaveError(const std::string& error) {
  {
    std::lock_guard<std::mutex> lock(impl_->m);
    impl_->counts.last_save = "failed: " + error;
  }
  impl_->publishStatus();
}

void LiveViewFeed::drain() {
  std::unique_lock<std::mutex> lock(impl_->m);
  impl_->idle.wait(lock, [&] { return impl_->queue.empty() && !impl_->busy; });
}

LiveStatus LiveViewFeed::status() const { return impl_->status(); }

std::string liveViewUrl(const std::string& listen, int port, const std::string& token) {
  std::string host = listen.substr(0, listen.rfind(':'));
  if (host.size() > 2 && host.front() == '[') host = host.substr(1, host.size() - 2);
  if (host.empty() || host == "0.0.0.0" || host == "::") {
    char name[256] = "";
    host = ::gethostname(name, sizeof name - 1) == 0 && name[0] ? name : "localhost";
  }
  if (host.find(':') != std::string::npos) host = "[" + host + "]";
  return "http://" + host + ":" + std::to_string(port) + "/" + (token.empty() ? "" : "?token=" + token);
}

}  // namespace hazmap
