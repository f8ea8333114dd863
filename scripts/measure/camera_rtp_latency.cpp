// Camera frames over RTP on loopback as `hazmap replay --camera` sends them and `hazmap live
// --camera-pipeline` receives them (GstFrameSender → udpsrc ! rtpgstdepay ! appsink): frames
// lost, and latency from the send call to (a) the frame's stamp (its PTS on CLOCK_REALTIME, what
// the labeler matches scans with) and (b) the frame reaching the sink callback (what a scan waits
// for). Usage: camera_rtp_latency [FRAMES=300] [FPS=30, 0 = as fast as possible] [WIDTHxHEIGHT=640x512]
#include <fmt/format.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <ctime>
#include <mutex>
#include <thread>
#include <vector>

#include "hazmap/sources/gst_camera.hpp"

namespace {

std::int64_t nowNs() {
  timespec t;
  ::clock_gettime(CLOCK_REALTIME, &t);
  return std::int64_t{t.tv_sec} * 1'000'000'000 + t.tv_nsec;
}

int freeUdpPort() {
  const int s = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  ::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t n = sizeof a;
  ::getsockname(s, reinterpret_cast<sockaddr*>(&a), &n);
  ::close(s);
  return ntohs(a.sin_port);
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5))];
}

}  // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 300;
  const double fps = argc > 2 ? std::atof(argv[2]) : 30.0;
  int width = 640, height = 512;
  if (argc > 3) std::sscanf(argv[3], "%dx%d", &width, &height);
  const int port = freeUdpPort();
  std::vector<std::int64_t> sent(static_cast<std::size_t>(frames), 0);
  std::mutex m;
  std::vector<double> stamp_ms, delivered_ms;
  std::size_t received = 0;
  hazmap::GstFrameReceiver receiver(hazmap::GstFrameSender::receiverPipeline(port), "receiver",
                                    [&](hazmap::CameraFrame&& f) {
                                      const std::int64_t at = nowNs();
                                      std::uint32_t id = 0;
                                      std::memcpy(&id, f.data.data(), sizeof id);
                                      std::lock_guard<std::mutex> lock(m);
                                      if (id >= sent.size() || sent[id] == 0) return;
                                      ++received;
                                      stamp_ms.push_back(double(f.time_ns - sent[id]) * 1e-6);
                                      delivered_ms.push_back(double(at - sent[id]) * 1e-6);
                                    });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the receiver's pipeline is playing
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(width) * height * 2);
  for (std::size_t k = 0; k < bytes.size(); ++k) bytes[k] = static_cast<std::uint8_t>(k * 7);
  {
    hazmap::GstFrameSender sender("127.0.0.1", port, "sender");
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < frames; ++i) {
      if (fps > 0) std::this_thread::sleep_until(start + std::chrono::duration<double>(i / fps));
      const auto id = static_cast<std::uint32_t>(i);
      std::memcpy(bytes.data(), &id, sizeof id);
      {
        std::lock_guard<std::mutex> lock(m);
        sent[id] = nowNs();
      }
      sender.send(width, height, "GRAY16_LE", bytes, std::int64_t(i) * 33'333'333);
    }
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  std::lock_guard<std::mutex> lock(m);
  fmt::print("{}x{} GRAY16_LE, {} frames at {}: received {} (lost {}); send → stamp p50 {:.2f} ms p99 {:.2f} ms, "
             "send → sink p50 {:.2f} ms p99 {:.2f} ms max {:.2f} ms\n",
             width, height, frames, fps > 0 ? fmt::format("{} fps", fps) : std::string("max"), received,
             frames - static_cast<int>(received), percentile(stamp_ms, 0.5), percentile(stamp_ms, 0.99),
             percentile(delivered_ms, 0.5), percentile(delivered_ms, 0.99), percentile(delivered_ms, 1.0));
  return 0;
}
