// hazmap live and hazmap replay over loopback (issue 33): a real capture replayed at 1× gives the
// frames and poses of `hazmap run` on the same capture; --rate max counts its losses and skips
// the scans they fell into; SIGINT/SIGTERM write a complete run folder, kill -9 leaves the last
// autosave; the spool re-reads as the live stream read; bad set-ups are one-line errors.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <iostream>
#include <functional>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/properties/camera.hpp"
#include "hazmap/sources/live_source.hpp"
#include "hazmap/sources/pcap_reader.hpp"
#include "hazmap/sources/pcap_writer.hpp"
#include "live_test_helpers.hpp"
#include "test_helpers.hpp"

extern char** environ;

namespace hazmap::test {
namespace {

namespace fs = std::filesystem;

const char* kVlp16 = "sensors/velodyne-vlp16-pcap/velodyne_vlp16.pcap";
const char* kOuster = "sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3.pcap";
const char* kOusterMeta = "sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10.json";

std::string readAll(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// `hazmap live …` in the background, its output in a log file.
class LiveProcess {
 public:
  LiveProcess(const std::string& args, fs::path log) : log_(std::move(log)) {
    const std::string command = "exec " + cliPath() + " live " + args + " > '" + log_.string() + "' 2>&1";
    const char* argv[] = {"/bin/sh", "-c", command.c_str(), nullptr};
    if (::posix_spawn(&pid_, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ) != 0) pid_ = -1;
  }
  ~LiveProcess() {
    if (pid_ > 0 && !exited_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  /// Waits (at most 20 s × timeScale()) for the "listening" line; false if the process ended or never said it.
  bool waitListening() {
    for (int i = 0; i < rounds(400); ++i) {
      if (readAll(log_).find("listening on UDP port") != std::string::npos) return true;
      if (::waitpid(pid_, &status_, WNOHANG) == pid_) return exited_ = true, false;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  }
  /// Waits (at most 20 s × timeScale()) for `text` in the output.
  bool waitFor(const std::string& text) {
    for (int i = 0; i < rounds(400); ++i) {
      if (readAll(log_).find(text) != std::string::npos) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  }
  /// Sends `signal` and waits for the exit (a SIGKILL after 25 s × timeScale()); the exit code.
  int stop(int signal) {
    ::kill(pid_, signal);
    for (int i = 0; i < rounds(500) && !exited_; ++i) {
      if (::waitpid(pid_, &status_, WNOHANG) == pid_) exited_ = true;
      else std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    if (!exited_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, &status_, 0);
      exited_ = true;
    }
    return WIFEXITED(status_) ? WEXITSTATUS(status_) : 128 + WTERMSIG(status_);
  }
  std::string log() const { return readAll(log_); }

 private:
  fs::path log_;
  pid_t pid_ = -1;
  int status_ = 0;
  bool exited_ = false;
};

/// `hazmap replay CAPTURE ARGS --quiet --port PORT` in the background until stop() (or the end of
/// the scope): the sensor a live test listens to.
class BackgroundReplay {
 public:
  BackgroundReplay(const fs::path& capture, std::uint16_t port, const std::string& args) {
    const std::string command = "exec " + cliPath() + " replay '" + capture.string() + "' " + args +
                                " --quiet --port " + std::to_string(port);
    const char* argv[] = {"/bin/sh", "-c", command.c_str(), nullptr};
    if (::posix_spawn(&pid_, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ) != 0) pid_ = -1;
  }
  ~BackgroundReplay() { stop(); }
  BackgroundReplay(const BackgroundReplay&) = delete;
  BackgroundReplay& operator=(const BackgroundReplay&) = delete;
  bool started() const { return pid_ > 0; }
  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }

 private:
  pid_t pid_ = -1;
};

std::size_t datagramsIn(const fs::path& capture) {
  PcapReader reader(capture);
  UdpPacket p;
  std::size_t n = 0;
  while (reader.next(p)) ++n;
  return n;
}

/// Every pose of `live` within 1 mm and 0.01° of `run`'s, and as many.
void expectSamePoses(const fs::path& run, const fs::path& live) {
  const Trajectory a = readKittiTrajectory(run / "trajectory.kitti");
  const Trajectory b = readKittiTrajectory(live / "trajectory.kitti");
  ASSERT_EQ(a.size(), b.size()) << "frames of hazmap run vs hazmap live";
  ASSERT_GT(a.size(), 1u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_LT(transErr(a.poses[i], b.poses[i]), 1e-3) << "frame " << i;
    EXPECT_LT(rotErrDeg(a.poses[i], b.poses[i]), 0.01) << "frame " << i;
  }
}

nlohmann::json liveSection(const fs::path& dir) {
  return nlohmann::json::parse(readTextFile(dir / "run.json")).at("live");
}

/// The live view's port from `hazmap live`'s output (0 until it printed it).
int viewPort(const std::string& log) {
  const std::string mark = "live view: http://127.0.0.1:";
  const auto at = log.find(mark);
  return at == std::string::npos ? 0 : std::stoi(log.substr(at + mark.size()));
}

/// `hazmap run` on the capture, then live + replay at `rate`, stopped by `signal`.
struct ReplayRun {
  fs::path run_dir, live_dir;
  int live_exit = -1;
  std::string live_log;
};

/// `silent_first`: the replay starts only once live reported the sensor silent.
ReplayRun replayAgainstRun(const std::string& capture, const std::string& live_args, const std::string& rate,
                           int signal, bool silent_first = false, const std::string& run_args = "",
                           const std::string& replay_args = "", std::string* status = nullptr,
                           const std::function<bool(const nlohmann::json&)>& status_done = {}) {
  ReplayRun r;
  const fs::path dir = scratchDir();
  r.run_dir = dir / "run";
  r.live_dir = dir / "live";
  const auto run = runCli("run '" + capture + "' --quiet --no-viewer " + run_args + " --out '" + r.run_dir.string() + "'");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  const std::uint16_t port = freePortPair();
  // The live view on (any free port): drawing the run must not change it.
  LiveProcess live(live_args + " --port " + std::to_string(port) + " --listen 127.0.0.1:0 --no-viewer --out '" + r.live_dir.string() +
                       "'",
                   dir / "live.log");
  EXPECT_TRUE(live.waitListening()) << live.log();
  if (silent_first) EXPECT_TRUE(live.waitFor("waiting for sensor on UDP port")) << live.log();
  const auto replay = runCli("replay '" + capture + "' --to 127.0.0.1 --port " + std::to_string(port) +
                             " --rate " + rate + " " + replay_args);
  EXPECT_EQ(replay.exit_code, 0) << replay.output;
  // The signal only once live has read all the replay sent: /status's packets no longer grow and
  // its queue is empty. A slow build (a sanitizer's) is still behind when the replay ends; what is
  // queued is tracked after the signal, what the kernel still holds would be lost. The status is
  // refreshed four times a second; `status_done` may ask more of it.
  const int view = viewPort(live.log());
  EXPECT_GT(view, 0) << live.log();
  std::size_t last_packets = SIZE_MAX;
  for (int i = 0; view > 0 && i < rounds(200); ++i) {
    const std::string body = httpGet(view, "/status");
    const auto j = nlohmann::json::parse(body, nullptr, false);
    if (!j.is_discarded()) {
      if (status) *status = body;
      const auto packets = j.value("packets", std::size_t{0});
      const bool drained = j.value("queue_datagrams", 1) == 0 && packets == last_packets;
      last_packets = packets;
      if (drained && (!status_done || status_done(j))) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  r.live_exit = live.stop(signal);
  r.live_log = live.log();
  return r;
}

TEST(LiveReplay, VelodyneCaptureAtOneGivesTheRunsFramesAndPoses) {
  const std::string capture = sharedData(kVlp16).string();
  const ReplayRun r = replayAgainstRun(capture, "--sensor velodyne", "1", SIGINT);
  ASSERT_EQ(r.live_exit, 0) << r.live_log;
  expectSamePoses(r.run_dir, r.live_dir);
  const auto live = liveSection(r.live_dir);
  EXPECT_EQ(live.at("received").get<std::size_t>(), datagramsIn(capture));
  EXPECT_EQ(live.at("lost").get<std::size_t>(), 0u);
  EXPECT_EQ(live.at("state").get<std::string>(), "stopped by SIGINT");
  // The run folder is one `hazmap eval` and `hazmap view` take.
  const auto eval = runCli("eval --gt '" + (r.run_dir / "trajectory.kitti").string() + "' --est '" +
                           (r.live_dir / "trajectory.kitti").string() + "' --align none --delta 1 --delta-unit frames");
  EXPECT_EQ(eval.exit_code, 0) << eval.output;
  const auto view = runCli("view '" + r.live_dir.string() + "'");
  EXPECT_EQ(view.exit_code, 0) << view.output;
  EXPECT_TRUE(fs::exists(r.live_dir / "viewer.html"));
}

TEST(LiveReplay, OusterCaptureWithImuPacketsAtOneGivesTheRunsFramesAndPoses) {
  const std::string capture = sharedData(kOuster).string();
  const std::string meta = sharedData(kOusterMeta).string();
  const ReplayRun r = replayAgainstRun(capture, "--sensor ouster --sensor-metadata '" + meta + "'", "1", SIGTERM);
  ASSERT_EQ(r.live_exit, 0) << r.live_log;
  expectSamePoses(r.run_dir, r.live_dir);
  const auto live = liveSection(r.live_dir);
  EXPECT_EQ(live.at("received").get<std::size_t>(), datagramsIn(capture));  // the IMU's too, on port + 1
  EXPECT_EQ(live.at("lost").get<std::size_t>(), 0u);
  EXPECT_EQ(live.at("state").get<std::string>(), "stopped by SIGTERM");
}

TEST(LiveReplay, VelodyneBagPacketsGoToTheDataPortAndGiveTheRunsPoses) {
  // A rosbag2 of VelodyneScan messages: each packet is sent on its own at its own stamp.
  const std::string bag = sharedData("sensors/velodyne-vlp16").string();
  // The sensor is silent first: live says so once and takes the stream when it comes.
  const ReplayRun r = replayAgainstRun(bag, "--sensor VLP-16", "1", SIGINT, true);
  ASSERT_EQ(r.live_exit, 0) << r.live_log;
  expectSamePoses(r.run_dir, r.live_dir);
  EXPECT_EQ(liveSection(r.live_dir).at("lost").get<std::size_t>(), 0u);
  EXPECT_EQ(liveSection(r.live_dir).at("silences").get<std::size_t>(), 1u);
  EXPECT_NE(r.live_log.find("sensor back on UDP port"), std::string::npos) << r.live_log;
}

TEST(LiveSimulated, NarahaAsVelodynePacketsReplayedLiveGivesTheRunsPoses) {
  // simulate --format pcap: the simulated VLP-16 as Velodyne packets, frames 10 s apart, replayed
  // at 50× (the run takes seconds). The simulated scans are instantaneous, so neither run
  // deskews: compressing the capture's clock would otherwise change the per-point times.
  // Beside the test's folder: replayAgainstRun makes that folder afresh.
  const std::string capture = (scratchDir().parent_path() / "LiveSimulated.naraha.pcap").string();
  const auto sim = runCli("simulate --frames 12 --format pcap --overwrite --out '" + capture + "'");
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  ScanSourceOptions options;
  std::size_t points = 0, frames = 0;
  for (auto s = openScanSource(capture, options); auto scan = s->next(); ++frames) points += scan->cloud.size();
  EXPECT_EQ(frames, 12u);
  EXPECT_GT(points, 12u * 20000u);  // the simulated VLP-16's returns come back from the packets
  const ReplayRun r = replayAgainstRun(capture, "--sensor velodyne --no-deskew", "50", SIGINT, false, "--no-deskew");
  ASSERT_EQ(r.live_exit, 0) << r.live_log;
  expectSamePoses(r.run_dir, r.live_dir);
  EXPECT_EQ(liveSection(r.live_dir).at("lost").get<std::size_t>(), 0u);
}

TEST(LiveSimulated, NarahaWithItsThermalCameraReplayedLiveGivesTheRunsHazards) {
  // simulate --format pcap --cameras thermal keeps the camera's images beside the capture; replay
  // sends them as RTP (rtpgstpay) on the capture's clock, live labels each scan from the frame
  // nearest its time: the hazards (and poses) of `hazmap run CAPTURE --camera` on the same input.
  const fs::path base = scratchDir().parent_path() / "LiveSimulated.thermal.pcap";
  const auto sim = runCli("simulate --frames 12 --cameras thermal --format pcap --overwrite --out '" + base.string() + "'");
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  const std::string yaml = (base.parent_path() / "LiveSimulated.thermal.cameras" / "thermal" / "camera.yaml").string();
  ASSERT_TRUE(fs::exists(yaml)) << sim.output;
  const std::uint16_t camera_port = freePortPair();
  const std::string pipeline = "udpsrc port=" + std::to_string(camera_port) +
                               " buffer-size=16777216 caps=\"application/x-rtp,media=application,clock-rate=90000,"
                               "encoding-name=X-GST\" ! rtpgstdepay ! appsink name=thermal";
  std::string status;
  const ReplayRun r = replayAgainstRun(base.string(),
                                       "--sensor velodyne --no-deskew --camera '" + yaml + "' --camera-pipeline '" + pipeline + "'",
                                       "50", SIGINT, false, "--no-deskew --camera '" + yaml + "'",
                                       "--camera '" + yaml + "' --camera-port " + std::to_string(camera_port), &status,
                                       [](const nlohmann::json& j) {
                                         return j.contains("cameras") && j["cameras"].size() == 1 &&
                                                j["cameras"][0].value("frames", 0) >= 12 && j.value("hazards", 0) >= 1;
                                       });
  ASSERT_EQ(r.live_exit, 0) << r.live_log;
  expectSamePoses(r.run_dir, r.live_dir);
  const auto run_hazards = nlohmann::json::parse(readTextFile(r.run_dir / "hazards.json"));
  const auto live_hazards = nlohmann::json::parse(readTextFile(r.live_dir / "hazards.json"));
  EXPECT_GE(run_hazards.at("count").get<int>(), 1);  // the simulated hot spots are seen
  ASSERT_EQ(live_hazards.at("count"), run_hazards.at("count"));
  for (std::size_t k = 0; k < run_hazards.at("hazards").size(); ++k) {
    const auto& a = run_hazards["hazards"][k];
    const auto& b = live_hazards["hazards"][k];
    EXPECT_EQ(a.at("class"), b.at("class"));
    EXPECT_EQ(a.at("cells"), b.at("cells"));
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(a["centroid"][i].get<double>(), b["centroid"][i].get<double>(), 1e-3);
    EXPECT_NEAR(a["channels"]["temperature"]["max"].get<double>(), b["channels"]["temperature"]["max"].get<double>(), 1e-3);
  }
  const auto live = liveSection(r.live_dir);
  EXPECT_EQ(live.at("lost").get<std::size_t>(), 0u);
  ASSERT_EQ(live.at("cameras").size(), 1u);
  EXPECT_EQ(live["cameras"][0].at("frames").get<int>(), 12);  // every image arrived whole
  EXPECT_EQ(live["cameras"][0].at("scans_without_image").get<int>(), 0);
  // /status after the replay: the camera's frames, and hazards found by the live view's map.
  const auto s = nlohmann::json::parse(status.empty() ? "{}" : status);
  ASSERT_TRUE(s.contains("cameras")) << status;
  EXPECT_EQ(s["cameras"][0].at("frames").get<int>(), 12);
  EXPECT_GE(s.at("hazards").get<int>(), 1);
}

TEST(LiveSimulated, DemoLiveReplaysTheMissionToLiveAndWritesTheRunFolder) {
  // hazmap demo --live: simulate → replay on loopback → live, the page's address printed; the run
  // folder written when the replay ends, the temporary capture gone.
  const fs::path dir = scratchDir();
  const auto r = runCli("demo --live --frames 6 --rate 50 --listen 127.0.0.1:0 --out '" + dir.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("live view: http://127.0.0.1:"), std::string::npos) << r.output;
  const auto at = r.output.find("wrote ") + 6;  // the simulation's line names the capture
  ASSERT_NE(r.output.find("hazmap-demo-live-", at), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(r.output.substr(at, r.output.find("/mission.pcap", at) - at))) << "the capture stayed";
  EXPECT_EQ(readKittiTrajectory(dir / "live" / "trajectory.kitti").size(), 6u);
  const auto live = liveSection(dir / "live");
  EXPECT_EQ(live.at("lost").get<std::size_t>(), 0u);
  EXPECT_EQ(live.at("state").get<std::string>(), "stopped by end of stream");
}

std::size_t linesStartingWith(const std::string& text, const std::string& prefix) {
  std::size_t n = 0;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) n += line.rfind(prefix, 0) == 0;
  return n;
}

// SIGINT mid-stream while the back end's thread is behind in its loop stages (the simulated naraha
// route replayed at 50 scans/s: each keyframe's loop search and verification cost more than
// tracking; /status's back_end_backlog says how many frames the graph lags): the run folder has
// every frame tracked, each once in the trajectory and in the graph.
TEST(LiveSimulated, SigintWhileTheBackEndVerifiesLoopsWritesACompleteRunFolder) {
  const fs::path dir = scratchDir();
  const fs::path capture = dir / "naraha.pcap";
  const auto sim = runCli("simulate --frames 163 --format pcap --overwrite --out '" + capture.string() + "'");
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  const std::uint16_t port = freePortPair();
  LiveProcess live("--sensor velodyne --method icp+pgo --no-deskew --no-viewer --listen 127.0.0.1:0 --port " +
                       std::to_string(port) +
                       " --out '" + (dir / "live").string() + "'",
                   dir / "live.log");
  ASSERT_TRUE(live.waitListening()) << live.log();
  BackgroundReplay sender(capture, port, "--rate 500");
  ASSERT_TRUE(sender.started());
  nlohmann::json busy;  // the status when the back end was seen behind, past the first loop
  for (int i = 0; i < rounds(600) && busy.is_null(); ++i) {  // at most ~30 s
    const auto j = nlohmann::json::parse(httpGet(viewPort(live.log()), "/status"), nullptr, false);
    if (!j.is_discarded() && j.value("frames", 0) >= 100 && j.value("back_end_backlog", 0) >= 3) busy = j;
    else std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_FALSE(busy.is_null()) << "the back end was never seen behind\n" << live.log();
  std::cout << "SIGINT at frame " << busy["frames"] << ", the back end " << busy["back_end_backlog"] << " frames behind\n";
  EXPECT_EQ(live.stop(SIGINT), 0) << live.log();
  sender.stop();
  const fs::path out = dir / "live";
  const Trajectory t = readKittiTrajectory(out / "trajectory.kitti");
  const auto run = nlohmann::json::parse(readTextFile(out / "run.json"));
  EXPECT_EQ(run.at("live").at("state").get<std::string>(), "stopped by SIGINT");
  EXPECT_EQ(run.at("live").at("map").get<std::string>(), "rebuilt from the spool");
  // Before the exact rebuild the end's state was written at once with the re-placed map.
  EXPECT_NE(live.log().find(std::to_string(t.size()) + " frames to " + out.string() + " (the map re-placed); rebuilding"),
            std::string::npos) << live.log();
  EXPECT_EQ(run.at("frames").get<std::size_t>(), t.size());
  EXPECT_EQ(linesStartingWith(readTextFile(out / "graph.g2o"), "VERTEX_SE3:QUAT "), t.size());
  EXPECT_EQ(linesStartingWith(readTextFile(out / "trajectory.kitti"), ""), t.size());
  std::cout << "the run folder has " << t.size() << " of the capture's 163 frames\n";
  EXPECT_GE(t.size(), busy.at("frames").get<std::size_t>());  // every frame tracked before the signal
  EXPECT_LE(t.size(), 163u);
  EXPECT_GT(run.at("loop_closure").at("keyframes_searched").get<std::size_t>(), 0u);
  const auto view = runCli("view '" + out.string() + "'");  // the folder is one `hazmap view` takes
  EXPECT_EQ(view.exit_code, 0) << view.output;
}

TEST(LiveReplay, HesaiBagPacketsGiveTheRunsFramesAndPoses) {
  const std::string bag = sharedData("sensors/hesai-pandar64/1673403880599376836").string();
  const ReplayRun r = replayAgainstRun(bag, "--sensor hesai", "1", SIGINT);
  ASSERT_EQ(r.live_exit, 0) << r.live_log;
  expectSamePoses(r.run_dir, r.live_dir);
  EXPECT_EQ(liveSection(r.live_dir).at("lost").get<std::size_t>(), 0u);
}

TEST(LiveReplay, RateMaxCountsWhatItLosesAndSkipsThoseScans) {
  const std::string capture = sharedData(kOuster).string();
  const std::string meta = sharedData(kOusterMeta).string();
  // A queue of 1 MiB holds some 40 of the 192 lidar packets while the first scan is tracked.
  const ReplayRun r =
      replayAgainstRun(capture, "--sensor ouster --queue-mb 1 --sensor-metadata '" + meta + "'", "max", SIGINT);
  ASSERT_EQ(r.live_exit, 0) << r.live_log;
  const auto live = liveSection(r.live_dir);
  const auto lost = live.at("lost").get<std::size_t>();
  EXPECT_EQ(lost, live.at("kernel_dropped").get<std::size_t>() + live.at("queue_dropped").get<std::size_t>() +
                      live.at("truncated").get<std::size_t>());
  EXPECT_EQ(live.at("received").get<std::size_t>() + live.at("kernel_dropped").get<std::size_t>(),
            datagramsIn(capture));
  EXPECT_GT(live.at("queue_dropped").get<std::size_t>(), 0u);
  // Every scan kept is one the capture holds whole (same point count), none with a hole.
  ScanSourceOptions options;
  options.sensor_metadata = sharedData(kOusterMeta);
  std::set<std::size_t> whole;
  for (auto s = openScanSource(capture, options); auto scan = s->next();) whole.insert(scan->cloud.size());
  std::size_t kept = 0;
  for (auto s = openLiveSpool(r.live_dir / "live.pcap", LiveSensor::Ouster, options); auto scan = s->next(); ++kept)
    EXPECT_TRUE(whole.count(scan->cloud.size())) << "scan " << kept << " has " << scan->cloud.size() << " points";
  EXPECT_EQ(readKittiTrajectory(r.live_dir / "trajectory.kitti").size(), kept);
  EXPECT_LE(kept + live.at("scans_skipped").get<std::size_t>(), whole.size());
}

TEST(LiveReplay, KillNineLeavesTheLastAutosaveReadable) {
  const fs::path dir = scratchDir();
  const std::uint16_t port = freePortPair();
  LiveProcess live("--sensor velodyne --autosave-every 0.2 --no-viewer --no-view --port " + std::to_string(port) +
                       " --out '" + (dir / "live").string() + "'",
                   dir / "live.log");
  ASSERT_TRUE(live.waitListening()) << live.log();
  BackgroundReplay sender(sharedData(kVlp16), port, "--loop");
  ASSERT_TRUE(sender.started());
  bool saved = false;
  for (int i = 0; i < rounds(400) && !saved; ++i) {  // at most 20 s
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    saved = live.log().find("autosaved") != std::string::npos;
  }
  EXPECT_EQ(live.stop(SIGKILL), 128 + SIGKILL);
  sender.stop();
  ASSERT_TRUE(saved) << live.log();
  const Trajectory t = readKittiTrajectory(dir / "live" / "trajectory.kitti");
  EXPECT_GT(t.size(), 0u);
  const auto j = nlohmann::json::parse(readTextFile(dir / "live" / "run.json"));
  EXPECT_EQ(j.at("frames").get<std::size_t>(), t.size());
  EXPECT_EQ(j.at("live").at("state").get<std::string>(), "autosave while running");
  // The autosave's map was composed from the segments built beside tracking, not the spool.
  EXPECT_TRUE(j["live"].value("map", "").starts_with("re-placed from")) << j["live"].dump();
}

// A save that fails while running (here: trajectory.kitti cannot be written, a directory stands
// in its way) is a notice; tracking goes on, and once the way is clear the end writes the folder.
TEST(LiveReplay, ASaveThatFailsWhileRunningLeavesTheSessionRunning) {
  const fs::path dir = scratchDir();
  const std::uint16_t port = freePortPair();
  const fs::path out = dir / "live";
  fs::create_directories(out / "trajectory.kitti" / "blocked");
  LiveProcess live("--sensor velodyne --autosave-every 0.2 --no-viewer --no-view --port " + std::to_string(port) +
                       " --out '" + out.string() + "'",
                   dir / "live.log");
  ASSERT_TRUE(live.waitListening()) << live.log();
  BackgroundReplay sender(sharedData(kVlp16), port, "--loop");
  ASSERT_TRUE(sender.started());
  std::size_t failures = 0;
  for (int i = 0; i < rounds(400) && failures < 2; ++i) {  // two failed saves, at most 20 s
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const std::string log = live.log();
    failures = 0;
    for (auto at = log.find("notice: save failed"); at != std::string::npos; at = log.find("notice: save failed", at + 1))
      ++failures;
  }
  fs::remove_all(out / "trajectory.kitti");
  EXPECT_EQ(live.stop(SIGINT), 0) << live.log();
  sender.stop();
  EXPECT_GE(failures, 2u) << live.log();
  const Trajectory t = readKittiTrajectory(out / "trajectory.kitti");
  EXPECT_GT(t.size(), 0u);
  const auto j = nlohmann::json::parse(readTextFile(out / "run.json"));
  EXPECT_EQ(j.at("frames").get<std::size_t>(), t.size());
  EXPECT_EQ(j.at("live").at("state").get<std::string>(), "stopped by SIGINT");
}

TEST(LiveSpool, ALossMarkSkipsTheScanItFellInto) {
  const fs::path dir = scratchDir();
  const fs::path capture = sharedData(kVlp16);
  ScanSourceOptions options;
  std::size_t whole = 0;
  for (auto s = openScanSource(capture, options); s->next();) ++whole;
  // The capture as a spool, a datagram inside the last scan lost on the way.
  const std::size_t lost_at = datagramsIn(capture) * 3 / 4;
  {
    PcapWriter spool(dir / "live.pcap");
    PcapReader reader(capture);
    UdpPacket p;
    for (std::size_t i = 0; reader.next(p); ++i) {
      if (i == lost_at) {
        const std::uint64_t one = 1;
        spool.write(p.time_ns, kSpoolLossPort, {reinterpret_cast<const std::uint8_t*>(&one), sizeof one});
        continue;
      }
      spool.write(p.time_ns, p.destination_port, p.payload);
    }
  }
  std::size_t kept = 0;
  for (auto s = openLiveSpool(dir / "live.pcap", LiveSensor::Velodyne, options); s->next();) ++kept;
  EXPECT_GE(whole, 2u);
  EXPECT_EQ(kept, whole - 1);
}

TEST(LiveSpool, WriterRoundTripsTimesPortsAndPayloads) {
  const fs::path path = scratchDir() / "w.pcap";
  const std::vector<std::uint8_t> a(1206, 7), b(33000, 9);
  {
    PcapWriter w(path);
    w.write(1'650'410'295'398'681'123, 2368, a);
    w.write(1'650'410'295'500'000'001, 7503, b, 7502);
    EXPECT_EQ(w.datagrams(), 2u);
    EXPECT_NE(errorOf([&] { w.write(0, 1, std::vector<std::uint8_t>(70000)); }), "");
  }
  PcapReader r(path);
  UdpPacket p;
  ASSERT_TRUE(r.next(p));
  EXPECT_EQ(p.time_ns, 1'650'410'295'398'681'123);
  EXPECT_EQ(p.destination_port, 2368);
  EXPECT_EQ(std::vector<std::uint8_t>(p.payload.begin(), p.payload.end()), a);
  ASSERT_TRUE(r.next(p));
  EXPECT_EQ(p.destination_port, 7503);
  EXPECT_EQ(p.source_port, 7502);
  EXPECT_EQ(p.payload.size(), b.size());
  EXPECT_FALSE(r.next(p));
  EXPECT_FALSE(r.loss().anyLost());
}

TEST(LiveErrors, CameraPipelinesThatCannotRunAreOneLineErrors) {
  const fs::path dir = scratchDir();
  writeTextAtomically(dir / "cam.yaml", cameraYaml(smallCamera("camera"), ""));
  const std::string base = "live --sensor velodyne --port 0 --listen 127.0.0.1:0 --camera '" + (dir / "cam.yaml").string() + "'";
  for (const auto& [pipeline, says] : std::vector<std::pair<std::string, std::string>>{
           {"nosuchelement ! appsink", "does not parse"},
           {"videotestsrc ! fakesink", "no appsink"},
           {"v4l2src device=/dev/no-such-camera ! appsink", "no-such-camera"}}) {
    const auto r = runCli(base + " --camera-pipeline '" + pipeline + "' --out '" + (dir / "out").string() + "'");
    EXPECT_NE(r.exit_code, 0) << pipeline;
    EXPECT_NE(r.output.find("--camera-pipeline of camera: "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(says), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("Segmentation"), std::string::npos);
  }
  const auto r = runCli(base + " --out '" + (dir / "out").string() + "'");  // a camera without its pipeline
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--camera-pipeline: give one per --camera (1 cameras, 0 pipelines)"), std::string::npos) << r.output;
}

TEST(LiveErrors, PortInUseUnknownSensorAndOusterWithoutMetadata) {
  const fs::path dir = scratchDir();
  const int taken = bindUdp(0);
  const std::uint16_t port = boundPort(taken);
  auto r = runCli("live --sensor velodyne --port " + std::to_string(port) + " --out '" + (dir / "a").string() + "'");
  ::close(taken);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("UDP port " + std::to_string(port) + ": already in use"), std::string::npos) << r.output;
  r = runCli("live --sensor lidar9000 --out '" + (dir / "b").string() + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--sensor: 'lidar9000' is no sensor"), std::string::npos) << r.output;
  r = runCli("live --sensor ouster --port 0 --out '" + (dir / "c").string() + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--sensor-metadata: an Ouster sensor needs its metadata JSON"), std::string::npos)
      << r.output;
  // The live view: another address without a token, a token too short or in a missing file, an
  // address in use; each before anything is received.
  r = runCli("live --sensor velodyne --port 0 --listen 0.0.0.0:0 --out '" + (dir / "d").string() + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("live view: listening on 0.0.0.0:0 (not loopback) needs --token"), std::string::npos) << r.output;
  r = runCli("live --sensor velodyne --port 0 --listen 127.0.0.1:0 --token abc --out '" + (dir / "e").string() + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--token: a token is 8 to 200 characters"), std::string::npos) << r.output;
  r = runCli("live --sensor velodyne --port 0 --token-file '" + (dir / "no-token").string() + "' --out '" +
             (dir / "f").string() + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("no-token"), std::string::npos) << r.output;
  const int tcp = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(tcp, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ::listen(tcp, 1);
  socklen_t length = sizeof a;
  ::getsockname(tcp, reinterpret_cast<sockaddr*>(&a), &length);
  const std::string in_use = "127.0.0.1:" + std::to_string(ntohs(a.sin_port));
  r = runCli("live --sensor velodyne --port 0 --listen " + in_use + " --out '" + (dir / "g").string() + "'");
  ::close(tcp);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("live view: cannot listen on " + in_use), std::string::npos) << r.output;
  r = runCli("replay '" + (dir / "missing.pcap").string() + "' --rate 1");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("missing.pcap"), std::string::npos) << r.output;
  r = runCli("replay '" + sourceDir("tests/labels.cmake").string() + "' --rate fast");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--rate: 'fast' is no rate"), std::string::npos) << r.output;
  r = runCli("replay '" + sourceDir("tests/labels.cmake").string() + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("labels.cmake: is neither a packet capture"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace hazmap::test
