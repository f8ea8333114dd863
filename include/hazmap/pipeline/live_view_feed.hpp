#pragma once
// The live view (issue 33, part 4): the viewer page in live mode, served by a LiveViewServer,
// fed from a running SLAM. onFrame() runs on the pipeline's thread and only copies the frame
// into a bounded queue; a thread of the feed's own turns it into messages (pose, trajectory
// point, new map voxels, hazards) and publishes them, and refreshes the status line every
// quarter second, also while the pipeline waits for a silent sensor. The server's publish()
// only queues per browser, so neither a slow view thread nor a slow browser slows tracking:
// when the view's queue is full a frame's scan is skipped for the view (its pose still goes).
#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/map/global_map.hpp"
#include "hazmap/map/hazards.hpp"
#include "hazmap/map/live_view_server.hpp"
#include "hazmap/pipeline/live_map_voxels.hpp"
#include "hazmap/pipeline/live_view_messages.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "hazmap/sources/udp_receiver.hpp"

namespace hazmap {

struct LiveViewFeedConfig {
  LiveViewConfig server;
  LiveMapConfig map;
  /// Hazards are found again (on the view's own map of the scans with property points) at most
  /// this often (s).
  double hazards_every = 1.0;
  GlobalMapConfig hazard_map;
  HazardConfig hazards;
  /// Scans waiting for the view's thread, at most (bytes); beyond it a scan is skipped for the view.
  std::size_t queue_bytes = std::size_t(64) << 20;
  /// No datagram for longer than this (s): state "waiting for sensor".
  double silence_seconds = 1.0;
  std::string title = "hazmap live";
  /// The live property cameras' counts for the status (thread-safe; empty: no cameras).
  std::function<std::vector<LiveCameraStats>()> cameras;
  std::filesystem::path three_dir = "/usr/share/javascript/three";  ///< ViewerConfig::three_dir
};

class LiveViewFeed {
 public:
  /// Starts the server (throws hazmap::Error naming the address) and the view's thread.
  /// `receiver`: the sensor's counts (thread-safe; empty: none). `on_save`: POST /save.
  LiveViewFeed(LiveViewFeedConfig config, ClassTable classes, std::function<UdpReceiverStats()> receiver,
               LiveViewServer::SaveHandler on_save);
  ~LiveViewFeed();
  LiveViewFeed(const LiveViewFeed&) = delete;
  LiveViewFeed& operator=(const LiveViewFeed&) = delete;

  int port() const;
  /// The pipeline's hook (SlamSnapshots::frame): copies and returns. `latency_s`: the scan's
  /// newest point to its pose (the status line's `latency_ms` over the most recent frames).
  void onFrame(const SlamFrameEvent& event, std::optional<double> latency_s = std::nullopt);
  /// Overrides the status line's state ("saving", "stopped by SIGINT"); empty: computed again.
  void setState(const std::string& state);
  /// When a save's state was taken and how long writing it took (the status line's last_save_*).
  struct SaveTiming {
    std::size_t frames = 0;
    std::chrono::steady_clock::time_point taken{};  ///< its snapshot
    double seconds = 0.0;                           ///< writing it
  };
  /// A save finished: the run folder's hazards (what hazards.json holds) replace the live ones,
  /// `trajectory` (the saved estimate) replaces the drawn one; `where` is shown in the status.
  void showSaved(const std::vector<Hazard>& hazards, const Trajectory& trajectory, const std::string& where,
                 std::optional<SaveTiming> timing = std::nullopt);
  void showSaveError(const std::string& error);
  /// Waits until every queued frame was published (tests, the end of a run).
  void drain();
  LiveStatus status() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

/// The URL an operator opens: http://HOST:PORT/ (?token=T when set); 0.0.0.0 and :: become this
/// machine's host name.
std::string liveViewUrl(const std::string& listen, int port, const std::string& token);

}  // namespace hazmap
