#pragma once
// Loopback helpers of the live tests (test_live, test_live_view_feed, test_live_browser): free
// UDP ports for `hazmap live`, and a plain HTTP GET with civetweb's client.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <civetweb.h>

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <string>
#include <thread>

#include "hazmap/properties/camera.hpp"

namespace hazmap::test {

#ifndef HAZMAP_TEST_TIME_SCALE_DEFAULT
#define HAZMAP_TEST_TIME_SCALE_DEFAULT 1.0  // sanitizer builds: 6 (tests/CMakeLists.txt)
#endif

/// How many times longer than on a plain build a live test waits for a process, a thread or a
/// browser: `HAZMAP_TEST_TIME_SCALE` from the environment (a slow machine), else the build's
/// default. Deadlines only, never expectations: no result may depend on it.
inline double timeScale() {
  static const double scale = [] {
    const char* v = std::getenv("HAZMAP_TEST_TIME_SCALE");
    const double s = v ? std::atof(v) : HAZMAP_TEST_TIME_SCALE_DEFAULT;
    return s >= 1.0 ? s : 1.0;
  }();
  return scale;
}

/// `n` polling rounds, stretched by timeScale().
inline int rounds(int n) { return static_cast<int>(n * timeScale()); }

/// Polls `done` every `poll` until it holds (true) or `seconds` × timeScale() have passed (false),
/// so that a failure cannot hang the suite.
inline bool waitUntil(const std::function<bool()>& done, double seconds = 10.0,
                      std::chrono::milliseconds poll = std::chrono::milliseconds(20)) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds * timeScale());
  while (!done()) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(poll);
  }
  return true;
}

inline int bindUdp(std::uint16_t port) {
  const int s = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_ANY);
  a.sin_port = htons(port);
  if (::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(s);
    return -1;
  }
  return s;
}

inline std::uint16_t boundPort(int s) {
  sockaddr_in a{};
  socklen_t n = sizeof a;
  ::getsockname(s, reinterpret_cast<sockaddr*>(&a), &n);
  return ntohs(a.sin_port);
}

/// A free UDP port P with P + 1 free too (live's auxiliary port): the kernel picks P.
inline std::uint16_t freePortPair() {
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int a = bindUdp(0);
    const std::uint16_t p = boundPort(a);
    const int b = p < 65535 ? bindUdp(static_cast<std::uint16_t>(p + 1)) : -1;
    ::close(a);
    if (b >= 0) {
      ::close(b);
      return p;
    }
  }
  ADD_FAILURE() << "no free UDP port pair";
  return 0;
}

/// A pinhole camera of `width`×`height` looking along the LiDAR's z (focal length = width · 0.78).
inline CameraCalibration smallCamera(const std::string& name, int width = 64, int height = 48) {
  CameraIntrinsics k;
  k.width = width, k.height = height, k.fx = k.fy = 0.78125 * width, k.cx = width / 2.0, k.cy = height / 2.0;
  CameraCalibration c;
  c.name = name;
  c.model = CameraModel(k, name);
  return c;
}

/// The body of GET `path` on 127.0.0.1:`port` ("" when nothing answered).
inline std::string httpGet(int port, const std::string& path) {
  char error[256] = "";
  mg_connection* conn = mg_connect_client("127.0.0.1", port, 0, error, sizeof error);
  if (!conn) return "";
  mg_printf(conn, "GET %s HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n", path.c_str());
  std::string body;
  if (mg_get_response(conn, error, sizeof error, 5000) >= 0) {
    char buf[4096];
    for (int n; (n = mg_read(conn, buf, sizeof buf)) > 0;) body.append(buf, std::size_t(n));
  }
  mg_close_connection(conn);
  return body;
}

}  // namespace hazmap::test
