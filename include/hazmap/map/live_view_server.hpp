#pragma once
// The live view's server (issue 33, part 4): HTTP + WebSocket over civetweb (Debian's
// libcivetweb-dev: a 25 kB C library that parses HTTP and WebSocket frames itself, so nothing
// here parses requests; Boost.Beast would add 138 MB of headers and minutes of template
// compilation to every fresh build). The server only serves what it is given and never touches
// SLAM's threads: publishing queues a message for each browser and returns.
//
// Contract: GET of a registered file (the page at "/"), GET /status (the JSON last given to
// setStatus), POST /save (runs the save handler, answers its JSON), WebSocket at /ws (the
// snapshot, then every published message). No document root: no listing, no other path.
// With a token every request must carry it (`Authorization: Bearer T`, or `?token=T`), else 401;
// an address other than loopback refuses to start without one.
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace hazmap {

struct LiveViewConfig {
  std::string listen = "127.0.0.1:8080";  ///< ADDR:PORT; port 0 = any free port (tests)
  std::string token;                      ///< required on every request when set
  /// A browser whose unsent messages exceed this is dropped (it reconnects and gets a snapshot).
  std::size_t client_buffer_bytes = std::size_t(8) << 20;
  std::size_t max_clients = 64;  ///< WebSocket clients at once; more are refused
};

struct LiveViewStats {
  std::size_t clients = 0;          ///< connected WebSocket clients now
  std::size_t clients_dropped = 0;  ///< dropped for falling behind
  std::size_t messages_coalesced = 0;  ///< state messages replaced before they were sent
};

class LiveViewServer {
 public:
  /// JSON text answered to POST /save (the run folder written, or an error).
  using SaveHandler = std::function<std::string()>;
  /// Messages a new browser gets first (the map and hazards so far), in order.
  using SnapshotHandler = std::function<std::vector<std::string>()>;

  /// Starts listening; throws hazmap::Error naming the address (in use, not loopback without a
  /// token, malformed).
  LiveViewServer(LiveViewConfig config, SaveHandler on_save, SnapshotHandler snapshot);
  ~LiveViewServer();
  LiveViewServer(const LiveViewServer&) = delete;
  LiveViewServer& operator=(const LiveViewServer&) = delete;

  int port() const;
  /// Serves `body` at `url_path` ("/" for the page).
  void addFile(const std::string& url_path, const std::string& content_type, std::string body);
  void setStatus(std::string json);
  /// An update every browser must get (map points added, a hazard found), in order.
  void publish(std::string message);
  /// A state of which only the latest matters (the pose, the status line): replaces an unsent
  /// message of the same `key`.
  void publishState(const std::string& key, std::string message);
  LiveViewStats stats() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

/// True for addresses that only this machine reaches (127.0.0.0/8, ::1, localhost).
bool isLoopbackAddress(const std::string& host);

}  // namespace hazmap
