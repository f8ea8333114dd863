// The live view's messages and feed (issue 33, part 4): the /status contract, map voxels sent
// once and decoding to their points, hazards in the viewer's rows, and a feed driven by frames
// as runSlam gives them, watched through a WebSocket client on loopback.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <civetweb.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <iostream>
#include <map>
#include <functional>
#include <mutex>
#include <thread>

#include "hazmap/map/global_map.hpp"
#include "hazmap/map/hazards.hpp"
#include "hazmap/pipeline/live_view_feed.hpp"
#include "hazmap/pipeline/live_view_messages.hpp"
#include "live_test_helpers.hpp"
#include "pipeline/live_view_queue.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

using nlohmann::json;
using test::httpGet;
constexpr ClassId kNone = 0, kHeat = 1;

std::vector<std::uint8_t> unbase64(const std::string& text) {
  static const std::string table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::vector<std::uint8_t> out;
  std::uint32_t bits = 0;
  int n = 0;
  for (char c : text) {
    if (c == '=') break;
    bits = bits << 6 | std::uint32_t(table.find(c));
    if ((n += 6) >= 8) out.push_back(std::uint8_t(bits >> (n -= 8)));
  }
  return out;
}

/// The points of a "map" message: (index + 0.5) × voxel, with their group's class.
std::vector<std::pair<Eigen::Vector3d, ClassId>> decodeMap(const json& m) {
  const auto xyz = unbase64(m["xyz"].get<std::string>());
  const double voxel = m["voxel"].get<double>();
  std::vector<std::pair<Eigen::Vector3d, ClassId>> points;
  std::size_t at = 0;
  for (const auto& g : m["groups"])
    for (std::size_t k = 0; k < g["count"].get<std::size_t>(); ++k, ++at) {
      Eigen::Vector3d p;
      for (int a = 0; a < 3; ++a) {
        const std::size_t b = 6 * at + 2 * std::size_t(a);
        p[a] = (double(std::int16_t(std::uint16_t(xyz[b] | xyz[b + 1] << 8))) + 0.5) * voxel;
      }
      points.emplace_back(p, g["id"].get<ClassId>());
    }
  EXPECT_EQ(xyz.size(), 6 * at);
  EXPECT_EQ(unbase64(m["rgb"].get<std::string>()).size(), 3 * at);
  return points;
}

/// A pose from 7 numbers x y z qx qy qz qw (the messages' order).
template <typename Number>
Eigen::Isometry3d poseFrom(const Number* v) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::Quaterniond(double(v[6]), double(v[3]), double(v[4]), double(v[5])).normalized().toRotationMatrix();
  pose.translation() = Eigen::Vector3d(double(v[0]), double(v[1]), double(v[2]));
  return pose;
}

/// What the page draws (viewer_live.js, in C++): each "map" message's voxel centres kept in their
/// segment's coordinates (the message's pose⁻¹ × centre) and drawn at the segment's newest pose;
/// an "anchors" message moves segments. Points stay in arrival order.
struct PageModel {
  std::map<std::uint32_t, Eigen::Isometry3d> anchors;
  std::vector<std::pair<std::uint32_t, Eigen::Vector3d>> local;
  std::int64_t last_seq = -1;
  std::size_t anchor_messages = 0, anchor_bytes = 0, segments_moved = 0;

  void apply(const json& m) {
    if (m["type"] == "map") {
      if (m["seq"].get<std::int64_t>() <= last_seq) return;
      last_seq = m["seq"].get<std::int64_t>();
      const auto segment = m["segment"].get<std::uint32_t>();
      const std::vector<double> p = m["pose"].get<std::vector<double>>();
      const Eigen::Isometry3d pose = poseFrom(p.data());
      anchors.emplace(segment, pose);
      for (const auto& [centre, label] : decodeMap(m)) local.emplace_back(segment, pose.inverse() * centre);
    } else if (m["type"] == "anchors") {
      const auto ids = unbase64(m["segments"].get<std::string>()), values = unbase64(m["poses"].get<std::string>());
      const std::size_t n = m["count"].get<std::size_t>();
      EXPECT_EQ(ids.size(), 4 * n);
      EXPECT_EQ(values.size(), 28 * n);
      for (std::size_t i = 0; i < n; ++i) {
        std::uint32_t id = 0;
        float v[7];
        std::memcpy(&id, ids.data() + 4 * i, 4);
        std::memcpy(v, values.data() + 28 * i, 28);
        anchors[id] = poseFrom(v);
      }
      ++anchor_messages;
      anchor_bytes += m.dump().size();
      segments_moved += n;
    }
  }
  std::vector<Eigen::Vector3d> drawn() const {
    std::vector<Eigen::Vector3d> out;
    for (const auto& [segment, p] : local) out.push_back(anchors.at(segment) * p);
    return out;
  }
};

/// A 4 × 3 m floor with a 1 × 1 m heat patch (60 °C) above it, in the sensor frame.
LabeledCloud floorWithHeat() {
  LabeledCloud c;
  c.enableProperty();
  for (float x = 0; x < 4; x += 0.05f)
    for (float y = 0; y < 3; y += 0.05f) c.push_back({x, y, -0.5f}, kNone);
  for (float x = 1; x < 2; x += 0.05f)
    for (float y = 1; y < 2; y += 0.05f) c.push_back({x, y, -0.3f}, kHeat, 0, 0, 60.0f);
  return c;
}

TEST(LiveViewMessages, StatusCarriesTheContractsFields) {
  LiveStatus s;
  s.frames = 12;
  s.packets = 900;
  s.drops = 3;
  s.state = "waiting for sensor";
  s.hazards = 2;
  json j = json::parse(liveStatusJson(s));
  for (const char* key : {"frames", "packets", "drops", "state", "last_packet_age_s", "hazards"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["frames"], 12);
  EXPECT_EQ(j["packets"], 900);
  EXPECT_EQ(j["drops"], 3);
  EXPECT_EQ(j["state"], "waiting for sensor");
  EXPECT_TRUE(j["last_packet_age_s"].is_null());  // no datagram yet
  EXPECT_EQ(j["hazards"], 2);
  s.last_packet_age_s = 1.23456;
  j = json::parse(liveStatusMessage(s));
  EXPECT_EQ(j["type"], "status");
  EXPECT_NEAR(j["status"]["last_packet_age_s"].get<double>(), 1.235, 1e-9);
}

TEST(LiveViewMessages, MapVoxelsGoOnceInBoundedChunksAndDecodeToTheirPoints) {
  LiveMapConfig config;
  config.voxel = 0.2;
  config.chunk_points = 100;
  LiveMapVoxels voxels(ClassTable::defaults(), config);
  const LabeledCloud scan = floorWithHeat();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(-30.0, 7.0, 1.0);
  const auto messages = voxels.add(0, scan, pose);
  ASSERT_GT(messages.size(), 2u);
  std::size_t points = 0, heat = 0;
  for (std::size_t i = 0; i < messages.size(); ++i) {
    const json m = json::parse(messages[i]);
    EXPECT_EQ(m["type"], "map");
    EXPECT_EQ(m["seq"].get<std::size_t>(), i);
    const auto decoded = decodeMap(m);
    EXPECT_LE(decoded.size(), config.chunk_points);
    for (const auto& [p, label] : decoded) {
      // Each voxel centre lies within half a voxel (per axis) of a point of the scan, in the world.
      double best = 1e9;
      for (std::size_t k = 0; k < scan.size(); ++k)
        best = std::min(best, ((pose * scan.points[k].cast<double>()) - p).cwiseAbs().maxCoeff());
      EXPECT_LE(best, 0.1 + 1e-6);
      heat += label == kHeat;
    }
    points += decoded.size();
  }
  EXPECT_EQ(points, voxels.points());
  EXPECT_GT(heat, 0u);
  EXPECT_TRUE(voxels.add(1, scan, pose).empty());  // nothing new
  // The cap: once max_points are sent, new voxels are counted, not sent.
  config.max_points = 50;
  LiveMapVoxels capped(ClassTable::defaults(), config);
  std::size_t sent = 0;
  for (const auto& m : capped.add(0, scan, pose)) sent += decodeMap(json::parse(m)).size();
  EXPECT_EQ(sent, 50u);
  EXPECT_GT(capped.dropped(), 0u);
}

Eigen::Isometry3d alongX(double x, double yaw = 0) {
  Eigen::Isometry3d pose(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  pose.translation() = Eigen::Vector3d(x, 0, 0);
  return pose;
}

// A loop correction moves the map the page draws: the segments whose anchor moved are sent (and
// only those), the page's points land where the corrected poses put the scans, and a scan of
// the same place after the correction adds nothing the moved points already cover.
TEST(LiveViewMessages, ACorrectionMovesTheSegmentsThatMovedAndThePagesPointsFollow) {
  LiveMapConfig config;
  config.voxel = 0.2;
  config.segment_length = 2.0;
  LiveMapVoxels voxels(ClassTable::defaults(), config);
  const LabeledCloud scan = floorWithHeat();
  PageModel page;
  std::vector<Eigen::Isometry3d> poses;
  std::vector<std::size_t> frame_of_point;  // which frame's add() sent each page point
  std::vector<std::string> sent;
  for (std::size_t i = 0; i < 12; ++i) {  // 0.5 m apart: segments of 5 frames (0, 2.5, 5 m)
    poses.push_back(alongX(0.5 * double(i)));
    for (const auto& m : voxels.add(i, scan, poses.back())) sent.push_back(m), page.apply(json::parse(m));
    frame_of_point.resize(page.local.size(), i);
  }
  ASSERT_EQ(voxels.segments(), 3u);
  ASSERT_EQ(page.local.size(), voxels.points());
  EXPECT_TRUE(voxels.reanchor(poses).empty());  // nothing moved
  // The correction: frames 5 on turn by 0.2 rad about frame 5 and shift 0.7 m in y.
  std::vector<Eigen::Isometry3d> corrected = poses;
  const Eigen::Isometry3d pivot = poses[5];
  Eigen::Isometry3d bend(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()));
  bend.translation() = Eigen::Vector3d(0, 0.7, 0);
  for (std::size_t i = 5; i < corrected.size(); ++i) corrected[i] = pivot * bend * pivot.inverse() * poses[i];
  const std::string moved = voxels.reanchor(corrected);
  ASSERT_FALSE(moved.empty());
  const json anchors = json::parse(moved);
  EXPECT_EQ(anchors["type"], "anchors");
  EXPECT_EQ(anchors["count"], 2);  // segments 1 and 2; segment 0 stayed
  page.apply(anchors);
  const std::vector<Eigen::Vector3d> drawn = page.drawn();
  const std::vector<Eigen::Vector3d> own = voxels.drawnPoints();
  ASSERT_EQ(drawn.size(), own.size());
  double moved_by = 0;
  std::size_t moved_points = 0;
  for (std::size_t k = 0; k < drawn.size(); ++k) {
    EXPECT_LT((drawn[k] - own[k]).norm(), 1e-4) << k;  // float32 poses on the wire
    // The point moved with its frame: within half a voxel's diagonal of a scan point there.
    const std::size_t i = frame_of_point[k];
    double best = 1e9;
    for (const auto& q : scan.points) best = std::min(best, (corrected[i] * q.cast<double>() - drawn[k]).norm());
    EXPECT_LE(best, 0.2 * std::sqrt(3.0) / 2 + 1e-3) << "point " << k << " of frame " << i;
    if (i >= 5) moved_by += (drawn[k] - poses[i] * (corrected[i].inverse() * drawn[k])).norm(), ++moved_points;
  }
  EXPECT_GT(moved_by / double(moved_points), 0.3);  // they did move (from where they were drawn)
  // A scan at a corrected pose finds most of its voxels taken by the moved points (not all: the
  // moved voxel centres are a turned lattice, which leaves some cells of the world's grid empty);
  // against the voxels where the points were before, it would find far fewer taken.
  LiveMapVoxels stale(ClassTable::defaults(), config);
  for (std::size_t i = 0; i < 12; ++i) stale.add(i, scan, poses[i]);
  std::size_t fresh = 0, fresh_stale = 0;
  for (const auto& m : voxels.add(12, scan, corrected[8])) sent.push_back(m), fresh += decodeMap(json::parse(m)).size();
  for (const auto& m : stale.add(12, scan, corrected[8])) fresh_stale += decodeMap(json::parse(m)).size();
  std::cout << "a scan at a corrected pose adds " << fresh << " voxels (" << fresh_stale << " without re-keying)\n";
  EXPECT_LT(3 * fresh, 2 * fresh_stale);
  // A new browser: every map message, then every segment's pose, draws what the first one does.
  PageModel late;
  for (const auto& m : sent) late.apply(json::parse(m));
  const json all = json::parse(voxels.anchorsMessage());
  EXPECT_EQ(all["count"].get<std::size_t>(), voxels.segments());
  late.apply(all);
  const std::vector<Eigen::Vector3d> late_drawn = late.drawn(), now = voxels.drawnPoints();
  ASSERT_EQ(late_drawn.size(), now.size());
  for (std::size_t k = 0; k < now.size(); ++k) EXPECT_LT((late_drawn[k] - now[k]).norm(), 1e-4) << k;
}

TEST(LiveViewMessages, RecentLatencyIsThatOfTheLastFramesOnly) {
  RecentLatency recent(100);
  EXPECT_EQ(recent.summary().frames, 0u);
  for (int i = 0; i < 500; ++i) recent.add(1.0);  // a slow start …
  for (int i = 1; i <= 100; ++i) recent.add(0.001 * i);  // … then 1 to 100 ms
  const RecentLatency::Summary s = recent.summary();
  EXPECT_EQ(s.frames, 100u);
  EXPECT_NEAR(s.p50, 50.0, 1e-9);
  EXPECT_NEAR(s.p99, 99.0, 1e-9);
  EXPECT_NEAR(s.max, 100.0, 1e-9);
  LiveStatus status;
  EXPECT_TRUE(json::parse(liveStatusJson(status))["latency_ms"].is_null());
  status.latency_ms = s;
  const json j = json::parse(liveStatusJson(status))["latency_ms"];
  EXPECT_NEAR(j["p99"].get<double>(), 99.0, 1e-9);
  EXPECT_EQ(j["frames"], 100);
}

TEST(LiveViewMessages, HazardsMessageCarriesTheViewersRowsWithTheirValues) {
  GlobalMap map;
  map.insert(0, floorWithHeat(), Eigen::Isometry3d::Identity());
  const std::vector<Hazard> hazards = findHazards(map);
  ASSERT_EQ(hazards.size(), 1u);
  const json m = json::parse(liveHazardsMessage(hazards, ClassTable::defaults(), "live"));
  EXPECT_EQ(m["type"], "hazards");
  EXPECT_EQ(m["origin"], "live");
  ASSERT_EQ(m["hazards"].size(), 1u);
  const json& h = m["hazards"][0];
  EXPECT_EQ(h["id"], hazards[0].id);
  EXPECT_EQ(h["class"], hazards[0].class_name);
  EXPECT_NEAR(h["mean_property"].get<double>(), 60.0, 1e-3);
  EXPECT_NEAR(h["centroid"][0].get<double>(), hazards[0].centroid.x(), 1e-3);
  EXPECT_EQ(h["color"], "#e61919");  // the heat colour of map.ply
  const json pose = json::parse(livePoseMessage(4, Eigen::Isometry3d(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ())),
                                                FrameStatus::Tracked));
  EXPECT_EQ(pose["frame"], 4);
  EXPECT_NEAR(pose["yaw"].get<double>(), 0.5, 1e-4);
  EXPECT_EQ(pose["status"], "tracked");
}

// ---- the feed, through a WebSocket client ----------------------------------------------------

struct Browser {
  std::mutex m;
  std::vector<json> received;
  mg_connection* conn = nullptr;
  std::vector<json> copy() {
    std::lock_guard<std::mutex> lock(m);
    return received;
  }
  std::vector<json> ofType(const std::string& type) {
    std::vector<json> out;
    for (auto& j : copy())
      if (j["type"] == type) out.push_back(j);
    return out;
  }
};

int onMessage(mg_connection*, int bits, char* data, size_t size, void* user) {
  if ((bits & 0x0f) != MG_WEBSOCKET_OPCODE_TEXT) return 1;
  auto& b = *static_cast<Browser*>(user);
  std::lock_guard<std::mutex> lock(b.m);
  b.received.push_back(json::parse(std::string(data, size)));
  return 1;
}

bool connect(Browser& b, int port) {
  char error[256] = "";
  b.conn = mg_connect_websocket_client("127.0.0.1", port, 0, error, sizeof error, "/ws", nullptr, onMessage, nullptr, &b);
  return b.conn != nullptr;
}

bool eventually(const std::function<bool()>& done) {
  return test::waitUntil(done, 10, std::chrono::milliseconds(5));
}

std::int64_t nowNs(double seconds_ago) {
  timespec t;
  ::clock_gettime(CLOCK_REALTIME, &t);
  return std::int64_t{t.tv_sec} * 1'000'000'000 + t.tv_nsec - std::int64_t(seconds_ago * 1e9);
}

/// Frames along +x, 0.5 m apart, each seeing the floor with its heat patch.
struct FakeRun {
  std::vector<Eigen::Isometry3d> poses;
  std::size_t corrections = 0;
  void frame(LiveViewFeed& feed, const LabeledCloud& scan) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation().x() = 0.5 * double(poses.size());
    poses.push_back(pose);
    FrameRecord record;
    record.index = poses.size() - 1;
    record.status = FrameStatus::Tracked;
    feed.onFrame(SlamFrameEvent{record, scan, poses, corrections});
  }
};

TEST(LiveViewFeed, PublishesFramesCorrectionsHazardsAndTheStatusAndANewBrowserCatchesUp) {
  LiveViewFeedConfig config;
  config.server.listen = "127.0.0.1:0";
  config.hazards_every = 0;
  std::atomic<double> silent_for{0.0};
  UdpReceiverStats receiver;
  receiver.received = 4321;
  receiver.queue_dropped = 2;
  LiveViewFeed feed(config, ClassTable::defaults(), [&] {
    UdpReceiverStats r = receiver;
    r.last_received_ns = nowNs(silent_for.load());
    return r;
  }, [] { return std::string(R"({"saved":"x"})"); });
  Browser early;
  ASSERT_TRUE(connect(early, feed.port()));
  const LabeledCloud scan = floorWithHeat();
  FakeRun run;
  for (int i = 0; i < 5; ++i) run.frame(feed, scan);
  // A loop correction: every pose moved 1 m up; the whole trajectory is redrawn.
  for (auto& p : run.poses) p.translation().z() += 1.0;
  ++run.corrections;
  run.frame(feed, scan);
  feed.drain();
  ASSERT_TRUE(eventually([&] { return !early.ofType("trajectory").empty() && !early.ofType("hazards").empty(); }));
  ASSERT_TRUE(eventually([&] { const auto p = early.ofType("pose"); return !p.empty() && p.back()["frame"] == 5; }));
  EXPECT_EQ(early.ofType("track").size(), 5u);  // frames 0-4; frame 5 came with the redraw
  const json trajectory = early.ofType("trajectory").back();
  ASSERT_EQ(trajectory["points"].size(), 6u);
  EXPECT_NEAR(trajectory["points"][0][2].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(trajectory["points"][5][0].get<double>(), 2.5, 1e-9);
  // The map and the hazards moved with the correction (frames 0-4, segment 0, 1 m up; frame 5,
  // a segment of its own, was tracked after it): the floor at z = -0.5 and the heat patch at -0.3
  // of segment 0 are drawn at +0.5 and +0.7, frame 5's where it saw them.
  ASSERT_TRUE(eventually([&] { return !early.ofType("anchors").empty(); }));
  PageModel page;
  for (const auto& m : early.copy()) page.apply(m);
  ASSERT_GT(page.local.size(), 100u);
  const auto drawn_early = page.drawn();
  for (std::size_t k = 0; k < drawn_early.size(); ++k)
    if (page.local[k].first == 0) EXPECT_GT(drawn_early[k].z(), 0.3) << k;
    else EXPECT_LT(drawn_early[k].z(), 0.0) << k;
  EXPECT_TRUE(eventually([&] {  // the hazard frames 0-4 saw moved with them
    const auto h = early.ofType("hazards");
    return std::any_of(h.back()["hazards"].begin(), h.back()["hazards"].end(),
                       [](const json& x) { return std::abs(x["centroid"][2].get<double>() - 0.7) < 0.15; });
  }));
  const json hazards = early.ofType("hazards").back();
  EXPECT_EQ(hazards["origin"], "live");
  EXPECT_GE(hazards["hazards"].size(), 1u);
  EXPECT_EQ(hazards["hazards"][0]["class"], "heat");
  // /status: the contract, from the counts the feed was given.
  json status = json::parse(httpGet(feed.port(), "/status"));
  EXPECT_EQ(status["frames"], 6);
  EXPECT_EQ(status["packets"], 4321);
  EXPECT_EQ(status["drops"], 2);
  EXPECT_EQ(status["state"], "tracking");
  EXPECT_LT(status["last_packet_age_s"].get<double>(), 1.0);
  EXPECT_EQ(status["hazards"].get<std::size_t>(), hazards["hazards"].size());
  EXPECT_GT(status["map_points"].get<std::size_t>(), 100u);
  // Silent for > 1 s: waiting for sensor, by itself, and back again.
  silent_for = 5.0;
  EXPECT_TRUE(eventually([&] { return json::parse(httpGet(feed.port(), "/status"))["state"] == "waiting for sensor"; }));
  silent_for = 0.0;
  EXPECT_TRUE(eventually([&] { return json::parse(httpGet(feed.port(), "/status"))["state"] == "tracking"; }));
  // A browser joining now gets the same map (every voxel once) and the trajectory so far.
  Browser late;
  ASSERT_TRUE(connect(late, feed.port()));
  ASSERT_TRUE(eventually([&] { return !late.ofType("status").empty(); }));
  std::size_t early_points = 0, late_points = 0;
  for (const auto& m : early.ofType("map")) early_points += decodeMap(m).size();
  for (const auto& m : late.ofType("map")) late_points += decodeMap(m).size();
  EXPECT_EQ(late_points, early_points);
  EXPECT_EQ(late_points, status["map_points"].get<std::size_t>());
  PageModel late_page;  // its snapshot: the map messages, then where their segments are now
  for (const auto& m : late.copy()) late_page.apply(m);
  const auto early_drawn = page.drawn(), late_drawn = late_page.drawn();
  ASSERT_EQ(late_drawn.size(), early_drawn.size());
  for (std::size_t k = 0; k < early_drawn.size(); ++k) EXPECT_LT((late_drawn[k] - early_drawn[k]).norm(), 1e-4);
  EXPECT_EQ(late.ofType("trajectory").at(0)["points"].size(), 6u);
  // A save: the run folder's hazards replace the live ones. Before it the status has no save's
  // age; after it, the age of the saved state (taken 2 s before it was shown) and how long it took.
  EXPECT_TRUE(json::parse(httpGet(feed.port(), "/status"))["last_save_age_s"].is_null());
  const auto taken = std::chrono::steady_clock::now() - std::chrono::seconds(2);
  feed.showSaved({}, Trajectory{}, "/tmp/run", LiveViewFeed::SaveTiming{6, taken, 0.75});
  EXPECT_TRUE(eventually([&] { const auto h = late.ofType("hazards"); return !h.empty() && h.back()["origin"] == "saved"; }));
  EXPECT_TRUE(late.ofType("hazards").back()["hazards"].empty());
  const json saved = json::parse(httpGet(feed.port(), "/status"));
  EXPECT_EQ(saved["saves"], 1);
  EXPECT_EQ(saved["last_save_frames"], 6);
  EXPECT_DOUBLE_EQ(saved["last_save_seconds"].get<double>(), 0.75);
  ASSERT_TRUE(saved["last_save_age_s"].is_number());
  EXPECT_GE(saved["last_save_age_s"].get<double>(), 2.0);
  EXPECT_LT(saved["last_save_age_s"].get<double>(), 60.0);
  // The age grows while no save comes (the status is published every 250 ms at most).
  EXPECT_TRUE(eventually([&] {
    return json::parse(httpGet(feed.port(), "/status"))["last_save_age_s"].get<double>() >=
           saved["last_save_age_s"].get<double>() + 0.2;
  }));
  mg_close_connection(early.conn);
  mg_close_connection(late.conn);
}

// runSlam's frame hook on a simulated route with accepted loops: every frame is told once, in
// order, with the graph's poses so far; `corrections` moves exactly when earlier poses moved (an
// online optimisation); and a run with the hook gives the same estimate bit for bit.
TEST(LiveViewHook, TellsEveryFrameAndEachCorrectionAndChangesNothing) {
  const auto dir = test::writeSimulatedSequence("live-hook", "naraha", 1, 76);  // first loop at frame 72
  SlamConfig config = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  config.threads = 2;
  std::vector<std::vector<Eigen::Vector3d>> seen;
  std::vector<std::size_t> corrections;
  SlamSnapshots hooks;
  hooks.frame = [&](const SlamFrameEvent& e) {
    EXPECT_EQ(e.record.index, seen.size());
    EXPECT_EQ(e.poses.size(), seen.size() + 1);
    EXPECT_GT(e.scan.size(), 1000u);
    std::vector<Eigen::Vector3d> positions;
    for (const auto& p : e.poses) positions.push_back(p.translation());
    seen.push_back(std::move(positions));
    corrections.push_back(e.corrections);
  };
  const auto with_source = sequenceScanSource(Sequence::open(dir), false);
  const SlamResult with = runSlam(*with_source, config, {}, hooks);
  const SlamResult without = runSlam(Sequence::open(dir), config);
  ASSERT_EQ(seen.size(), with.frames.size());
  ASSERT_FALSE(with.loops.empty());
  EXPECT_GT(corrections.back(), 0u);
  for (std::size_t k = 1; k < seen.size(); ++k) {
    bool moved = false;
    for (std::size_t i = 0; i < k; ++i) moved |= seen[k][i] != seen[k - 1][i];
    EXPECT_EQ(moved, corrections[k] != corrections[k - 1]) << "frame " << k;
  }
  ASSERT_EQ(with.estimate.size(), without.estimate.size());
  for (std::size_t i = 0; i < with.estimate.size(); ++i)
    EXPECT_TRUE(with.estimate.poses[i].isApprox(without.estimate.poses[i], 0.0)) << "frame " << i;
}

// The live map on a simulated route with accepted loops (corrections from frame 72): after
// each online optimisation, the page's points (decoded from the messages as the page decodes
// them) are where the newest poses put the scans they came from, to within the segments' rigid
// approximation; drawn where they were first tracked, they would be off by more.
TEST(LiveViewHook, ALoopCorrectionMovesTheMapThePageDrawsToTheCorrectedPlace) {
  const auto dir = test::writeSimulatedSequence("live-map-loop", "naraha", 1, 76);
  SlamConfig config = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  config.threads = 2;
  LiveMapVoxels voxels(ClassTable::defaults());  // the feed's defaults: 0.2 m voxels, 2 m segments
  PageModel page;
  struct Sent {
    std::size_t frame;
    Eigen::Isometry3d pose;  // the frame's pose when the point was sent
    Eigen::Vector3d at;      // where the page drew it then
  };
  std::vector<Sent> sent;
  std::vector<Eigen::Isometry3d> newest;
  std::size_t corrections = 0;
  SlamSnapshots hooks;
  hooks.frame = [&](const SlamFrameEvent& e) {
    if (e.corrections != corrections) {
      corrections = e.corrections;
      if (const std::string m = voxels.reanchor(e.poses); !m.empty()) page.apply(json::parse(m));
    }
    for (const auto& m : voxels.add(e.record.index, e.scan, e.poses.back())) page.apply(json::parse(m));
    for (std::size_t k = sent.size(); k < page.local.size(); ++k)
      sent.push_back({e.record.index, e.poses.back(), page.anchors.at(page.local[k].first) * page.local[k].second});
    newest = e.poses;
  };
  const auto source = sequenceScanSource(Sequence::open(dir), false);
  const SlamResult result = runSlam(*source, config, {}, hooks);
  ASSERT_FALSE(result.loops.empty());
  ASSERT_GT(corrections, 0u);
  ASSERT_GT(page.anchor_messages, 0u);
  const std::vector<Eigen::Vector3d> drawn = page.drawn();
  ASSERT_EQ(drawn.size(), sent.size());
  std::vector<double> error, stale;
  for (std::size_t k = 0; k < drawn.size(); ++k) {
    const Eigen::Vector3d expected = newest[sent[k].frame] * (sent[k].pose.inverse() * sent[k].at);
    error.push_back((drawn[k] - expected).norm());
    stale.push_back((sent[k].at - expected).norm());
  }
  std::sort(error.begin(), error.end());
  std::sort(stale.begin(), stale.end());
  const auto p99 = [](const std::vector<double>& v) { return v[v.size() * 99 / 100]; };
  std::cout << "points " << drawn.size() << ", segments " << voxels.segments() << ", anchor messages "
            << page.anchor_messages << " (" << page.anchor_bytes << " bytes, " << page.segments_moved
            << " segments)\nerror p99 " << p99(error) << " max " << error.back() << "; not moved: p99 " << p99(stale)
            << " max " << stale.back() << "\n";
  // What is left is the segments' rigid approximation (and float32 poses on the wire): the change
  // of poses relative to their segment's anchor, well under the 0.2 m voxel. The simulated route's
  // corrections are small (ICP drifts little there); the unit tests above move by metres.
  EXPECT_LT(p99(error), 0.02);
  EXPECT_LT(error.back(), 0.05);
  EXPECT_GT(p99(stale), 2 * p99(error));  // drawn where first tracked, the map would be off by more
}

// A long mission while the view's thread (lowest priority) is starved: each correction carries
// every pose so far, so queued corrections would grow with the square of the frames. Only the
// newest waits; every frame and scan that fits the budget is still queued, in order.
TEST(LiveViewQueue, OnlyTheNewestCorrectionsPosesWaitAndTheScansStayWithinTheBudget) {
  LabeledCloud scan;
  scan.points.assign(1000, Eigen::Vector3f::Zero());
  scan.classes.assign(1000, kNone);
  const std::size_t bytes = pipeline_detail::scanBytes(scan);
  EXPECT_EQ(bytes, 1000 * (sizeof(Eigen::Vector3f) + sizeof(ClassId)));
  pipeline_detail::LiveViewQueue queue(10 * bytes);
  std::size_t frames = 0, scans = 0;
  for (std::size_t f = 0; f < 3000; ++f) {
    pipeline_detail::LiveViewItem item;
    item.frame = f;
    if (queue.reserve(bytes)) {
      item.scan = std::make_unique<LabeledCloud>(scan);
      item.bytes = bytes;
      ++scans;
    }
    if (f % 3 == 0) {  // a correction every third frame: all poses so far
      item.correction = true;
      item.corrected.assign(f + 1, Eigen::Isometry3d::Identity());
    }
    queue.push(std::move(item));
    ++frames;
    ASSERT_LE(queue.queuedPoses(), f + 1) << "frame " << f;
    ASSERT_LE(queue.bytes(), 10 * bytes);
  }
  EXPECT_EQ(scans, 10u);  // the budget's worth, the rest skipped for the view
  EXPECT_EQ(queue.superseded(), 999u);
  std::deque<pipeline_detail::LiveViewItem> batch = queue.take();
  ASSERT_EQ(batch.size(), frames);
  std::size_t corrections = 0;
  for (std::size_t i = 0; i < batch.size(); ++i) {
    EXPECT_EQ(batch[i].frame, i);
    corrections += batch[i].correction;
  }
  EXPECT_EQ(corrections, 1u);
  EXPECT_TRUE(batch[2997].correction);
  EXPECT_EQ(batch[2997].corrected.size(), 2998u);
  for (const auto& item : batch) queue.release(item.bytes);
  EXPECT_EQ(queue.bytes(), 0u);
  EXPECT_TRUE(queue.reserve(bytes));
  // A save's correction alone (no frame) that a later one supersedes leaves the queue.
  pipeline_detail::LiveViewItem saved, later;
  saved.has_frame = later.has_frame = false;
  saved.correction = later.correction = true;
  saved.corrected.assign(5, Eigen::Isometry3d::Identity());
  later.corrected.assign(6, Eigen::Isometry3d::Identity());
  queue.push(std::move(saved));
  queue.push(std::move(later));
  batch = queue.take();
  ASSERT_EQ(batch.size(), 1u);
  EXPECT_EQ(batch[0].corrected.size(), 6u);
}

TEST(LiveViewFeed, UrlNamesTheAddressAndTheToken) {
  EXPECT_EQ(liveViewUrl("127.0.0.1:0", 41234, ""), "http://127.0.0.1:41234/");
  EXPECT_EQ(liveViewUrl("127.0.0.1:8080", 8080, "abcdefgh12"), "http://127.0.0.1:8080/?token=abcdefgh12");
  EXPECT_EQ(liveViewUrl("[::1]:8080", 8080, ""), "http://[::1]:8080/");
  EXPECT_EQ(liveViewUrl("0.0.0.0:8080", 8080, "").find("http://0.0.0.0"), std::string::npos);
}

}  // namespace
}  // namespace hazmap
