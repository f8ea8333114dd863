// The live view's server (issue 33, part 4): files, /status, /save, the token, WebSocket updates
// in order, coalesced states, and a browser that stops reading is dropped without slowing the
// publisher. Loopback only, port 0 (a free port each).
#include <gtest/gtest.h>

#include <civetweb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "hazmap/core/error.hpp"
#include "hazmap/map/live_view_server.hpp"
#include "live_test_helpers.hpp"

using namespace hazmap;

namespace {

LiveViewConfig loopback() {
  LiveViewConfig c;
  c.listen = "127.0.0.1:0";
  return c;
}

struct Response {
  int status = 0;
  std::string body;
};

Response request(int port, const std::string& method, const std::string& path, const std::string& header = "") {
  char error[256] = "";
  mg_connection* conn = mg_connect_client("127.0.0.1", port, 0, error, sizeof error);
  if (conn == nullptr) return {-1, error};
  mg_printf(conn, "%s %s HTTP/1.1\r\nHost: 127.0.0.1\r\n%sContent-Length: 0\r\nConnection: close\r\n\r\n",
            method.c_str(), path.c_str(), header.c_str());
  Response r;
  if (mg_get_response(conn, error, sizeof error, 5000) >= 0) {
    r.status = mg_get_response_info(conn)->status_code;
    char buf[4096];
    for (int n; (n = mg_read(conn, buf, sizeof buf)) > 0;) r.body.append(buf, static_cast<std::size_t>(n));
  }
  mg_close_connection(conn);
  return r;
}

/// Waits (up to 10 s, so a failure cannot hang the suite) until `done` holds.
bool eventually(const std::function<bool()>& done) {
  return hazmap::test::waitUntil(done, 10, std::chrono::milliseconds(1));
}

struct Browser {
  std::mutex m;
  std::vector<std::string> received;
  mg_connection* conn = nullptr;
  std::vector<std::string> copy() {
    std::lock_guard<std::mutex> lock(m);
    return received;
  }
};

int onMessage(mg_connection*, int bits, char* data, size_t size, void* user) {
  if ((bits & 0x0f) != MG_WEBSOCKET_OPCODE_TEXT) return 1;
  auto& b = *static_cast<Browser*>(user);
  std::lock_guard<std::mutex> lock(b.m);
  b.received.emplace_back(data, size);
  return 1;
}

bool connectBrowser(Browser& b, int port, const std::string& path = "/ws") {
  char error[256] = "";
  b.conn = mg_connect_websocket_client("127.0.0.1", port, 0, error, sizeof error, path.c_str(), nullptr,
                                       onMessage, nullptr, &b);
  return b.conn != nullptr;
}

}  // namespace

TEST(LiveView, ServesItsFilesStatusAndSaveAndNothingElse) {
  int saves = 0;
  LiveViewServer server(loopback(), [&] { ++saves; return std::string(R"({"saved":"out"})"); }, nullptr);
  ASSERT_GT(server.port(), 0);
  server.addFile("/", "text/html", "<html>live</html>");
  server.setStatus(R"({"frames":3,"state":"tracking"})");
  EXPECT_EQ(request(server.port(), "GET", "/").body, "<html>live</html>");
  const Response status = request(server.port(), "GET", "/status");
  EXPECT_EQ(status.status, 200);
  EXPECT_EQ(status.body, R"({"frames":3,"state":"tracking"})");
  EXPECT_EQ(request(server.port(), "GET", "/save").status, 405);
  EXPECT_EQ(saves, 0);
  EXPECT_EQ(request(server.port(), "POST", "/save").body, R"({"saved":"out"})");
  EXPECT_EQ(saves, 1);
  EXPECT_EQ(request(server.port(), "GET", "/../../etc/passwd").status, 404);
  EXPECT_EQ(request(server.port(), "GET", "/tests").status, 404);
  EXPECT_EQ(request(server.port(), "DELETE", "/").status, 405);
}

TEST(LiveView, EveryRequestCarriesTheTokenWhenOneIsSet) {
  LiveViewConfig config = loopback();
  config.token = "s3cret-token";
  LiveViewServer server(config, [] { return std::string("{}"); }, nullptr);
  server.addFile("/", "text/html", "page");
  EXPECT_EQ(request(server.port(), "GET", "/").status, 401);
  EXPECT_EQ(request(server.port(), "GET", "/status").status, 401);
  EXPECT_EQ(request(server.port(), "POST", "/save").status, 401);
  EXPECT_EQ(request(server.port(), "GET", "/?token=wrong-token!").status, 401);
  EXPECT_EQ(request(server.port(), "GET", "/?token=s3cret-token").body, "page");
  EXPECT_EQ(request(server.port(), "GET", "/", "Authorization: Bearer s3cret-token\r\n").body, "page");
  Browser without, with;
  EXPECT_FALSE(connectBrowser(without, server.port()));
  EXPECT_TRUE(connectBrowser(with, server.port(), "/ws?token=s3cret-token"));
  if (with.conn) mg_close_connection(with.conn);
}

TEST(LiveView, RefusesAnotherAddressWithoutATokenAndAPortInUse) {
  LiveViewConfig open = loopback();
  open.listen = "0.0.0.0:0";
  try {
    LiveViewServer server(open, nullptr, nullptr);
    FAIL() << "a server on every address without a token";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("0.0.0.0:0 (not loopback) needs --token"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(isLoopbackAddress("127.0.0.1"));
  EXPECT_TRUE(isLoopbackAddress("127.8.0.2"));
  EXPECT_TRUE(isLoopbackAddress("::1"));
  EXPECT_FALSE(isLoopbackAddress("10.0.0.1"));
  EXPECT_FALSE(isLoopbackAddress("0.0.0.0"));
  LiveViewServer first(loopback(), nullptr, nullptr);
  LiveViewConfig same = loopback();
  same.listen = "127.0.0.1:" + std::to_string(first.port());
  EXPECT_THROW(LiveViewServer second(same, nullptr, nullptr), Error);
}

TEST(LiveView, BrowsersGetTheSnapshotThenEveryUpdateInOrderAndTheLatestState) {
  std::vector<std::string> history = {"map 0", "map 1"};
  LiveViewServer server(loopback(), nullptr, [&] { return history; });
  Browser b;
  ASSERT_TRUE(connectBrowser(b, server.port()));
  ASSERT_TRUE(eventually([&] { return b.copy().size() == 2; }));
  for (int i = 2; i < 200; ++i) server.publish("map " + std::to_string(i));
  for (int i = 0; i < 500; ++i) server.publishState("pose", "pose " + std::to_string(i));
  ASSERT_TRUE(eventually([&] { const auto r = b.copy(); return !r.empty() && r.back() == "pose 499"; }));
  const auto got = b.copy();
  std::vector<std::string> updates, poses;
  for (const auto& m : got) (m.rfind("map ", 0) == 0 ? updates : poses).push_back(m);
  ASSERT_EQ(updates.size(), 200u);
  for (int i = 0; i < 200; ++i) EXPECT_EQ(updates[static_cast<std::size_t>(i)], "map " + std::to_string(i));
  // Every pose either reached the browser or was replaced by a later one before it was sent.
  EXPECT_EQ(poses.size() + server.stats().messages_coalesced, 500u);
  EXPECT_EQ(server.stats().clients, 1u);
  mg_close_connection(b.conn);
  EXPECT_TRUE(eventually([&] { return server.stats().clients == 0; }));
}

namespace {

/// A client that completes the WebSocket handshake and never reads again (-1 on failure).
int stuckBrowser(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  const int small = 4096;
  ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return ::close(fd), -1;
  const std::string handshake =
      "GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
      "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n";
  if (::send(fd, handshake.data(), handshake.size(), 0) != static_cast<ssize_t>(handshake.size())) return ::close(fd), -1;
  return fd;
}

}  // namespace

TEST(LiveView, ABrowserThatStopsReadingIsDroppedAndSlowsNobody) {
  LiveViewConfig config = loopback();
  config.client_buffer_bytes = 1 << 20;
  LiveViewServer server(config, nullptr, nullptr);
  const int fd = stuckBrowser(server.port());
  ASSERT_GE(fd, 0);
  ASSERT_TRUE(eventually([&] { return server.stats().clients == 1; }));
  Browser reader;
  ASSERT_TRUE(connectBrowser(reader, server.port()));
  ASSERT_TRUE(eventually([&] { return server.stats().clients == 2; }));
  const std::string chunk(256 << 10, 'x');
  // 25 MB, far beyond the stuck client's 1 MB; the reader keeps up (each chunk waits for it).
  for (std::size_t i = 0; i < 100; ++i) {
    server.publish(chunk);
    ASSERT_TRUE(eventually([&] { return reader.copy().size() == i + 1; })) << "the reader stalled at " << i;
  }
  EXPECT_EQ(server.stats().clients_dropped, 1u);
  server.publish("last");
  EXPECT_TRUE(eventually([&] { const auto r = reader.copy(); return !r.empty() && r.back() == "last"; }));
  ::close(fd);
  mg_close_connection(reader.conn);
}

// A browser that keeps only how many messages came and whether each was the next in order.
struct CountingBrowser {
  std::atomic<std::size_t> received{0}, out_of_order{0};
  mg_connection* conn = nullptr;
};

int onCountedMessage(mg_connection*, int bits, char* data, size_t size, void* user) {
  if ((bits & 0x0f) != MG_WEBSOCKET_OPCODE_TEXT) return 1;
  auto& b = *static_cast<CountingBrowser*>(user);
  const std::string text(data, size);
  const std::size_t n = b.received.load();
  if (text.substr(text.find_last_of('x') + 1) != std::to_string(n)) ++b.out_of_order;
  b.received = n + 1;
  return 1;
}

// The issue's "fifty of them": 25 browsers that stop reading and 25 that read, at once. publish()
// never waits for any of them (it returns with every stuck browser's queue full), the stuck ones
// are dropped once their queues pass the bound (their connections close when they do), and every
// reader gets every message in order.
TEST(LiveView, FiftyBrowsersHalfOfThemStuckSlowNobody) {
  LiveViewConfig config = loopback();
  config.client_buffer_bytes = 1 << 20;
  LiveViewServer server(config, nullptr, nullptr);
  std::vector<int> stuck;
  for (int i = 0; i < 25; ++i) {
    stuck.push_back(stuckBrowser(server.port()));
    ASSERT_GE(stuck.back(), 0);
  }
  std::vector<std::unique_ptr<CountingBrowser>> readers;
  for (int i = 0; i < 25; ++i) {
    readers.push_back(std::make_unique<CountingBrowser>());
    char error[256] = "";
    readers.back()->conn = mg_connect_websocket_client("127.0.0.1", server.port(), 0, error, sizeof error, "/ws",
                                                       nullptr, onCountedMessage, nullptr, readers.back().get());
    ASSERT_NE(readers.back()->conn, nullptr) << error;
  }
  ASSERT_TRUE(eventually([&] { return server.stats().clients == 50; }));
  const std::string chunk(96 << 10, 'x');
  // 100 × 96 kB: 9.4 MB each, beyond a stuck browser's 1 MB and its socket's buffers (≤ 4 MB here).
  for (std::size_t i = 0; i < 100; ++i) {
    server.publish(chunk + std::to_string(i));
    for (auto& r : readers)
      ASSERT_TRUE(eventually([&] { return r->received.load() == i + 1; })) << "a reader stalled at " << i;
  }
  EXPECT_EQ(server.stats().clients_dropped, 25u);
  std::vector<std::thread> closing;  // a civetweb client's close waits out its reader's timeout (~1.6 s): at once
  for (auto& r : readers) {
    EXPECT_EQ(r->received.load(), 100u);
    EXPECT_EQ(r->out_of_order.load(), 0u);
    closing.emplace_back([conn = r->conn] { mg_close_connection(conn); });
  }
  for (auto& c : closing) c.join();
  for (const int fd : stuck) ::close(fd);
  EXPECT_TRUE(eventually([&] { return server.stats().clients == 0; })) << server.stats().clients << " still connected";
}
