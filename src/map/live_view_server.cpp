#include "hazmap/map/live_view_server.hpp"

#include <civetweb.h>

#include <arpa/inet.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <thread>
#include <utility>

#include "hazmap/core/error.hpp"

namespace hazmap {

// One browser: its own queue and sender thread, so a stuck one blocks nobody but itself.
struct LiveClient {
  mg_connection* conn = nullptr;
  std::mutex m;
  std::condition_variable wake;
  // Shared, not copied: fifty browsers cost one copy of a map chunk, not fifty.
  std::deque<std::shared_ptr<const std::string>> updates;
  std::size_t bytes = 0;
  std::vector<std::pair<std::string, std::shared_ptr<const std::string>>> states;  // coalesced, first-published order
  bool closing = false;
  bool dropped = false;
  std::thread sender;
};

struct LiveViewServer::Impl {
  LiveViewConfig config;
  SaveHandler on_save;
  SnapshotHandler snapshot;
  mg_context* ctx = nullptr;
  int port = 0;
  mutable std::mutex m;  // files, status, clients
  std::map<std::string, std::pair<std::string, std::string>> files;  // path -> (type, body)
  std::string status = "{}";
  std::map<const mg_connection*, std::shared_ptr<LiveClient>> clients;
  mutable std::atomic<std::size_t> dropped{0}, coalesced{0};

  bool authorised(const mg_connection* conn) const;
  void enqueue(LiveClient& c, std::shared_ptr<const std::string> message) const;
  void sendLoop(const std::shared_ptr<LiveClient>& c) const;
};

namespace {

bool sameSecret(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;  // the whole string, whatever matches first: no timing hint
  for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  return diff == 0;
}

void replyOk(mg_connection* conn, const std::string& type, const std::string& body) {
  mg_send_http_ok(conn, type.c_str(), static_cast<long long>(body.size()));
  mg_write(conn, body.data(), body.size());
}

// Written by hand: Debian's civetweb 1.15 spins in mg_send_http_error's header writer for 405.
void replyError(mg_connection* conn, int code, const char* text) {
  const char* reason = code == 401 ? "Unauthorized" : code == 404 ? "Not Found" : "Method Not Allowed";
  const char* extra = code == 401 ? "WWW-Authenticate: Bearer\r\n" : "";
  mg_printf(conn,
            "HTTP/1.1 %d %s\r\nContent-Type: text/plain\r\nContent-Length: %zu\r\n%s"
            "Cache-Control: no-store\r\nConnection: close\r\n\r\n%s\n",
            code, reason, std::strlen(text) + 1, extra, text);
}

std::pair<std::string, std::string> splitHostPort(const std::string& listen) {
  const auto colon = listen.rfind(':');
  if (colon == std::string::npos || colon + 1 == listen.size())
    throw Error("live view: --listen '" + listen + "' is not ADDR:PORT");
  std::string host = listen.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  return {host, listen.substr(colon + 1)};
}

}  // namespace

bool isLoopbackAddress(const std::string& host) {
  if (host == "localhost" || host == "::1") return true;
  in_addr a{};
  return inet_pton(AF_INET, host.c_str(), &a) == 1 && (ntohl(a.s_addr) >> 24) == 127;
}

bool LiveViewServer::Impl::authorised(const mg_connection* conn) const {
  if (config.token.empty()) return true;
  if (const char* h = mg_get_header(conn, "Authorization"))
    if (sameSecret(h, "Bearer " + config.token)) return true;
  const mg_request_info* ri = mg_get_request_info(conn);
  if (ri->query_string == nullptr) return false;
  char given[256];
  const int n = mg_get_var(ri->query_string, std::strlen(ri->query_string), "token", given, sizeof given);
  return n >= 0 && sameSecret(given, config.token);
}

void LiveViewServer::Impl::enqueue(LiveClient& c, std::shared_ptr<const std::string> message) const {
  std::lock_guard<std::mutex> lock(c.m);
  if (c.dropped || c.closing) return;
  c.bytes += message->size();
  c.updates.push_back(std::move(message));
  if (c.bytes > config.client_buffer_bytes) {  // fallen behind: drop it, it reconnects
    c.dropped = true;
    ++dropped;
    c.updates.clear();
    c.states.clear();
    c.bytes = 0;
  }
  c.wake.notify_one();
}

void LiveViewServer::Impl::sendLoop(const std::shared_ptr<LiveClient>& c) const {
  // A browser's sender yields to every other thread (nice 19): SLAM and the sensor come first.
  ::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), 19);
  for (;;) {
    std::deque<std::shared_ptr<const std::string>> batch;
    std::vector<std::pair<std::string, std::shared_ptr<const std::string>>> states;
    {
      std::unique_lock<std::mutex> lock(c->m);
      c->wake.wait(lock, [&] { return c->closing || c->dropped || !c->updates.empty() || !c->states.empty(); });
      if (c->closing) return;
      if (c->dropped) break;
      batch.swap(c->updates);
      states.swap(c->states);
      c->bytes = 0;
    }
    for (const auto& m : batch)
      if (mg_websocket_write(c->conn, MG_WEBSOCKET_OPCODE_TEXT, m->data(), m->size()) <= 0) return;
    for (const auto& s : states)
      if (mg_websocket_write(c->conn, MG_WEBSOCKET_OPCODE_TEXT, s.second->data(), s.second->size()) <= 0) return;
  }
  const char reason[] = "\x03\xe8" "fell behind";  // 1000, normal closure: the page reconnects
  mg_websocket_write(c->conn, MG_WEBSOCKET_OPCODE_CONNECTION_CLOSE, reason, sizeof reason - 1);
}

namespace {

int onHttp(mg_connection* conn, void* data) {
  auto& s = *static_cast<LiveViewServer::Impl*>(data);
  if (!s.authorised(conn)) {
    replyError(conn, 401, "a token is required (Authorization: Bearer TOKEN, or ?token=TOKEN)");
    return 401;
  }
  const mg_request_info* ri = mg_get_request_info(conn);
  const std::string method = ri->request_method, path = ri->local_uri;
  if (path == "/save") {
    if (method != "POST") return replyError(conn, 405, "POST /save"), 405;
    const std::string body = s.on_save ? s.on_save() : std::string("{}");
    replyOk(conn, "application/json", body);
    return 200;
  }
  if (method != "GET" && method != "HEAD") return replyError(conn, 405, "only GET and POST /save"), 405;
  std::pair<std::string, std::string> file;
  {
    std::lock_guard<std::mutex> lock(s.m);
    if (path == "/status") {
      file = {"application/json", s.status};
    } else {
      const auto it = s.files.find(path);
      if (it == s.files.end()) return replyError(conn, 404, "not found"), 404;
      file = it->second;
    }
  }
  replyOk(conn, file.first, method == "HEAD" ? std::string() : file.second);
  return 200;
}

int onWsConnect(const mg_connection* conn, void* data) {
  auto& s = *static_cast<LiveViewServer::Impl*>(data);
  if (!s.authorised(conn)) return 1;
  std::lock_guard<std::mutex> lock(s.m);
  return s.clients.size() >= s.config.max_clients ? 1 : 0;
}

void onWsReady(mg_connection* conn, void* data) {
  auto& s = *static_cast<LiveViewServer::Impl*>(data);
  auto c = std::make_shared<LiveClient>();
  c->conn = conn;
  // Snapshot and registration under the lock publish() takes: no message falls between them
  // (so the snapshot handler must be cheap: ready-made messages, not a map to serialise).
  std::lock_guard<std::mutex> lock(s.m);
  if (s.snapshot)
    for (auto& m : s.snapshot()) s.enqueue(*c, std::make_shared<const std::string>(std::move(m)));
  c->bytes = 0;  // the snapshot (bounded by what the caller keeps) does not count as falling behind
  c->sender = std::thread([&s, c] { s.sendLoop(c); });
  s.clients[conn] = std::move(c);
}

int onWsData(mg_connection*, int, char*, size_t, void*) { return 1; }  // keep-alives only

void onWsClose(const mg_connection* conn, void* data) {
  auto& s = *static_cast<LiveViewServer::Impl*>(data);
  std::shared_ptr<LiveClient> c;
  {
    std::lock_guard<std::mutex> lock(s.m);
    const auto it = s.clients.find(conn);
    if (it == s.clients.end()) return;
    c = std::move(it->second);
    s.clients.erase(it);
  }
  {
    std::lock_guard<std::mutex> lock(c->m);
    c->closing = true;
  }
  c->wake.notify_one();
  if (c->sender.joinable()) c->sender.join();
}

}  // namespace

LiveViewServer::LiveViewServer(LiveViewConfig config, SaveHandler on_save, SnapshotHandler snapshot)
    : impl_(std::make_unique<Impl>()) {
  auto& s = *impl_;
  s.config = std::move(config);
  s.on_save = std::move(on_save);
  s.snapshot = std::move(snapshot);
  const auto [host, port] = splitHostPort(s.config.listen);
  if (!isLoopbackAddress(host) && s.config.token.empty())
    throw Error("live view: listening on " + s.config.listen + " (not loopback) needs --token");
  mg_init_library(0);
  const std::string ports = (host.find(':') != std::string::npos ? "[" + host + "]" : host) + ":" + port;
  const std::string threads = std::to_string(s.config.max_clients + 8);  // a WebSocket holds a thread
  const char* options[] = {"listening_ports", ports.c_str(), "num_threads", threads.c_str(),
                           "request_timeout_ms", "10000", "websocket_timeout_ms", "30000",
                           "enable_websocket_ping_pong", "yes", nullptr};
  mg_callbacks callbacks{};
  mg_init_data init{&callbacks, impl_.get(), options};
  char error[256] = "";
  mg_error_data err{};
  err.text = error;
  err.text_buffer_size = sizeof error;
  s.ctx = mg_start2(&init, &err);
  if (s.ctx == nullptr) throw Error("live view: cannot listen on " + s.config.listen + ": " + error);
  mg_server_port bound[4];
  const int n = mg_get_server_ports(s.ctx, 4, bound);
  s.port = n > 0 ? bound[0].port : 0;
  mg_set_request_handler(s.ctx, "/", onHttp, impl_.get());
  mg_set_websocket_handler(s.ctx, "/ws", onWsConnect, onWsReady, onWsData, onWsClose, impl_.get());
}

LiveViewServer::~LiveViewServer() {
  if (impl_->ctx) mg_stop(impl_->ctx);  // closes every WebSocket (onWsClose joins its sender)
}

int LiveViewServer::port() const { return impl_->port; }

void LiveViewServer::addFile(const std::string& url_path, const std::string& content_type, std::string body) {
  std::lock_guard<std::mutex> lock(impl_->m);
  impl_->files[url_path] = {content_type, std::move(body)};
}

void LiveViewServer::setStatus(std::string json) {
  std::lock_guard<std::mutex> lock(impl_->m);
  impl_->status = std::move(json);
}

void LiveViewServer::publish(std::string message) {
  const auto shared = std::make_shared<const std::string>(std::move(message));
  std::lock_guard<std::mutex> lock(impl_->m);
  for (auto& [conn, c] : impl_->clients) impl_->enqueue(*c, shared);
}

void LiveViewServer::publishState(const std::string& key, std::string text) {
  const auto message = std::make_shared<const std::string>(std::move(text));
  std::lock_guard<std::mutex> lock(impl_->m);
  for (auto& [conn, c] : impl_->clients) {
    std::lock_guard<std::mutex> client_lock(c->m);
    if (c->dropped || c->closing) continue;
    auto it = std::find_if(c->states.begin(), c->states.end(), [&](const auto& s) { return s.first == key; });
    if (it != c->states.end()) {
      it->second = message;
      ++impl_->coalesced;
    } else {
      c->states.emplace_back(key, message);
    }
    c->wake.notify_one();
  }
}

LiveViewStats LiveViewServer::stats() const {
  std::lock_guard<std::mutex> lock(impl_->m);
  return {impl_->clients.size(), impl_->dropped.load(), impl_->coalesced.load()};
}

}  // namespace hazmap
