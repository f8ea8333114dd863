// hazmap replay CAPTURE.pcap|BAG --to HOST [--rate 1|2|max] [--loop] [--port N]: sends each UDP
// payload of a capture to its original port on HOST (a bag's LiDAR packets to the sensor's
// standard port), paced by the recording's clock, so `hazmap live` (or a sensor driver)
// receives what the sensor sent. Plain POSIX sockets: one socket,
// sendto per datagram, nothing Asio would add.
#include <arpa/inet.h>
#include <fmt/format.h>
#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <algorithm>
#include <cerrno>
#include <cstring>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <thread>

#include "command.hpp"
#include "hazmap/core/error.hpp"
#include "replay_cameras.hpp"
#include "replay_datagrams.hpp"

namespace hazmap::cli {
namespace {

struct ReplayOptions {
  std::string capture, to = "127.0.0.1", rate = "1";
  int port = -1;
  bool loop = false, quiet = false;
  std::vector<std::string> cameras;  ///< camera.yaml files whose images go as RTP
  int camera_port = 5000;
};

/// The capture's LiDAR data port: a sensor's standard one (2368, 7502) if present, else the
/// port that received the most bytes among the first datagrams.
std::uint16_t dataPort(const std::string& capture) {
  const auto datagrams = openReplayDatagrams(capture);
  std::map<std::uint16_t, std::size_t> bytes;
  ReplayDatagram packet;
  for (int i = 0; i < 2000 && datagrams->next(packet); ++i) {
    if (packet.port == 2368 || packet.port == 7502) return packet.port;
    bytes[packet.port] += packet.payload.size();
  }
  if (bytes.empty()) fail(capture, "capture holds no UDP datagram");
  return std::max_element(bytes.begin(), bytes.end(), [](auto& a, auto& b) { return a.second < b.second; })->first;
}

/// Speed-up over the capture's clock; 0 = as fast as the socket takes them.
double parseRate(const std::string& text) {
  if (text == "max") return 0.0;
  try {
    std::size_t used = 0;
    const double r = std::stod(text, &used);
    if (used == text.size() && r > 0 && r < 1e6) return r;
  } catch (const std::exception&) {
  }
  fail("--rate", "'" + text + "' is no rate: a positive factor (1, 2, 0.5) or max");
}

sockaddr_in resolve(const std::string& host) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  if (::getaddrinfo(host.c_str(), nullptr, &hints, &found) != 0 || !found)
    fail("--to", "'" + host + "' is no IPv4 address or known host name");
  sockaddr_in address;
  std::memcpy(&address, found->ai_addr, sizeof address);
  ::freeaddrinfo(found);
  return address;
}

struct Sent {
  std::uint64_t datagrams = 0, bytes = 0, refused = 0;
};

/// One pass over the capture (and the cameras' images, merged by time); the first datagram or
/// image sets the origin that maps capture time to wall time.
void replayOnce(const ReplayOptions& o, int socket, sockaddr_in address, double rate, std::uint16_t data_port,
                ReplayCameras& cameras, Sent& sent) {
  const auto datagrams = openReplayDatagrams(o.capture);
  ReplayDatagram packet;
  std::optional<std::int64_t> origin;
  const auto start = std::chrono::steady_clock::now();
  const auto pace = [&](std::int64_t time_ns) {
    if (!origin) origin = time_ns;
    if (rate > 0)
      std::this_thread::sleep_until(start + std::chrono::nanoseconds(static_cast<std::int64_t>(
                                                static_cast<double>(time_ns - *origin) / rate)));
  };
  cameras.rewind();
  while (datagrams->next(packet)) {
    cameras.sendUntil(packet.time_ns, pace);  // images stamped up to this datagram go first
    pace(packet.time_ns);
    std::uint16_t port = packet.port;
    if (o.port >= 0) port = static_cast<std::uint16_t>(port == data_port ? o.port : o.port + 1);
    address.sin_port = htons(port);
    if (::sendto(socket, packet.payload.data(), packet.payload.size(), 0, reinterpret_cast<sockaddr*>(&address),
                 sizeof address) < 0) {
      if (errno != ECONNREFUSED) fail(o.to, fmt::format("cannot send to port {}: {}", port, std::strerror(errno)));
      ++sent.refused;  // nobody listens there (loopback says so): counted, not an error
      continue;
    }
    ++sent.datagrams;
    sent.bytes += packet.payload.size();
  }
  cameras.sendUntil(std::nullopt, pace);
}

void replay(const ReplayOptions& o) {
  const double rate = parseRate(o.rate);
  if (o.port < -1 || o.port > 65534) fail("--port", std::to_string(o.port) + " is no UDP port (0-65534)");
  const std::uint16_t data_port = dataPort(o.capture);
  const sockaddr_in address = resolve(o.to);
  const int s = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (s < 0) fail("replay", std::string("cannot open a socket: ") + std::strerror(errno));
  std::unique_ptr<int, void (*)(int*)> closer(new int(s), [](int* fd) { ::close(*fd), delete fd; });
  ReplayCameras cameras(o.cameras, o.to, o.camera_port);
  Sent sent;
  const auto start = std::chrono::steady_clock::now();
  do replayOnce(o, s, address, rate, data_port, cameras, sent);
  while (o.loop);
  if (o.quiet) return;
  std::cout << fmt::format("sent {} datagrams ({} bytes){} to {} in {:.3f} s{}\n", sent.datagrams, sent.bytes,
                           cameras.count() ? fmt::format(" and {} camera images (RTP, port {}+)", cameras.sent(), o.camera_port) : "",
                           o.to,
                           std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                           sent.refused ? fmt::format(", {} refused (no listener)", sent.refused) : "");
}

const RegisterCommand registration{{
    "replay",
    "Send a capture's UDP payloads (or a bag's LiDAR packets) to their ports on a host, paced by the recording's clock (for hazmap live)",
    [](CLI::App& app) {
      auto o = std::make_shared<ReplayOptions>();
      app.add_option("capture", o->capture, "Packet capture (.pcap, .pcapng) or bag with LiDAR packet topics")->required();
      app.add_option("--to", o->to, "Host to send to");
      app.add_option("--rate", o->rate, "Speed-up over the capture's clock: 1, 2, 0.5, … or max (no pacing)");
      app.add_flag("--loop", o->loop, "Start over at the end, until interrupted");
      app.add_option("--port", o->port,
                     "Send the LiDAR data port's datagrams to this port and every other datagram to this + 1 "
                     "(as hazmap live --port listens); default: the original ports");
      app.add_option("--camera", o->cameras,
                     "Also send this camera's images (camera.yaml beside its NNNNNN.png and times.txt; repeatable) "
                     "as RTP (rtpgstpay, GRAY16_LE), each at its stamp");
      app.add_option("--camera-port", o->camera_port,
                     "UDP port of the first --camera's RTP stream (the next camera: + 1, ...)");
      app.add_flag("--quiet", o->quiet, "No summary line");
      app.callback([o] { replay(*o); });
    }}};

}  // namespace
}  // namespace hazmap::cli
