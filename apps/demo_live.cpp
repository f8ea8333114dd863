// hazmap demo --live: simulate → replay on loopback → live (see demo_live.hpp).
#include "demo_live.hpp"

#include <fmt/format.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <iostream>
#include <thread>
#include <vector>

#include "hazmap/core/error.hpp"

extern char** environ;

namespace hazmap::cli {
namespace {

/// This program again as a child with `args`; its pid.
pid_t spawnSelf(const std::vector<std::string>& args) {
  std::vector<std::string> all{"/proc/self/exe"};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  if (::posix_spawn(&pid, "/proc/self/exe", nullptr, nullptr, argv.data(), environ) != 0)
    fail("hazmap demo --live", "cannot start hazmap " + args.front());
  return pid;
}

int waitFor(pid_t pid) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

/// The replay child and the thread that ends the session when it exits.
struct Replay {
  std::atomic<pid_t> pid{-1};
  std::thread watcher;
  ~Replay() {
    if (pid > 0 && watcher.joinable()) ::kill(pid, SIGTERM);  // the session failed: no orphan
    if (watcher.joinable()) watcher.join();
  }
};

}  // namespace

void runLiveDemo(LiveDemoOptions o, const ParameterOptions& params) {
  const std::filesystem::path out = o.live.out;
  std::filesystem::create_directories(out);
  struct Scratch {
    std::filesystem::path path;
    ~Scratch() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);
    }
  } scratch{std::filesystem::temp_directory_path() / fmt::format("hazmap-demo-live-{}", ::getpid())};
  std::filesystem::create_directories(scratch.path);
  const std::string capture = (scratch.path / "mission.pcap").string();
  std::cout << fmt::format("simulating the {} mission as VLP-16 packets ({})\n", o.scenario,
                           o.frames ? std::to_string(o.frames) + " frames" : "the whole route")
            << std::flush;
  const int simulated = waitFor(spawnSelf({"simulate", "--scenario", o.scenario, "--seed", std::to_string(o.seed),
                                           "--frames", std::to_string(o.frames), "--format", "pcap", "--out", capture}));
  if (simulated != 0) fail("hazmap demo --live", "the simulation failed (exit " + std::to_string(simulated) + ")");
  o.live.sensor = "velodyne";
  o.live.port = 0;  // any free UDP port: the replay is told which
  o.live.no_deskew = true;  // simulated scans are instantaneous; a compressed clock must not skew them
  o.live.out = (out / "live").string();
  Replay replay;
  runLiveSession(o.live, params, [&](std::uint16_t port) {
    std::cout << fmt::format("replaying it at {}x to UDP port {}; Ctrl-C ends the run early\n", o.rate, port)
              << std::flush;
    replay.pid = spawnSelf({"replay", capture, "--to", "127.0.0.1", "--port", std::to_string(port), "--rate", o.rate,
                            "--quiet"});
    replay.watcher = std::thread([&replay] {
      waitFor(replay.pid);
      replay.pid = -1;
      stopLiveSession();  // what the socket holds is still decoded
    });
  });
}

}  // namespace hazmap::cli
