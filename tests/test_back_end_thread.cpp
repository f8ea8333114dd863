// The asynchronous back end (issue 33 part 3, SlamConfig::back_end own-thread): the same final
// answer as the synchronous schedule, tracking that never waits for a loop stage, and a stream
// that ends while a loop stage is in flight still gives complete outputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <mutex>
#include <random>
#include <string>
#include <thread>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/pipeline/frame_latency.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "hazmap/sources/forwarding_source.hpp"
#include "pipeline/edge_journal.hpp"
#include "pipeline/frame_record_store.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

/// A source that says when its stream has ended (next() gave nullopt).
class WatchedSource : public ForwardingScanSource {
 public:
  using ForwardingScanSource::ForwardingScanSource;
  std::optional<Scan> next() override {
    std::optional<Scan> scan = ForwardingScanSource::next();
    if (!scan) {
      std::lock_guard<std::mutex> lock(m);
      ended = true;
      changed.notify_all();
    }
    return scan;
  }
  std::mutex m;
  std::condition_variable changed;
  bool ended = false;
};

void expectSamePoses(const Trajectory& a, const Trajectory& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Eigen::Isometry3d d = a.poses[i].inverse() * b.poses[i];
    EXPECT_LE(translationNorm(d), 1e-3) << "frame " << i;
    EXPECT_LE(rotationAngle(d) * 180.0 / M_PI, 0.01) << "frame " << i;
  }
}

bool sameBits(const double* a, const double* b, std::size_t n) { return std::memcmp(a, b, n * sizeof(double)) == 0; }

// Every field, bit for bit (the wall time only for copies of one record).
void expectSameRecord(const FrameRecord& a, const FrameRecord& b, bool same_run = true) {
  EXPECT_EQ(a.index, b.index);
  EXPECT_TRUE(sameBits(&a.stamp, &b.stamp, 1)) << a.index;
  EXPECT_TRUE(sameBits(a.T_prev_curr.matrix().data(), b.T_prev_curr.matrix().data(), 16)) << a.index;
  EXPECT_TRUE(sameBits(a.covariance.data(), b.covariance.data(), 36)) << a.index;
  EXPECT_TRUE(sameBits(a.guess_covariance.data(), b.guess_covariance.data(), 36)) << a.index;
  EXPECT_EQ(a.icp_used, b.icp_used);
  EXPECT_EQ(a.status, b.status);
  EXPECT_EQ(a.fallback_reason, b.fallback_reason);
  EXPECT_TRUE(sameBits(&a.fitness, &b.fitness, 1) && sameBits(&a.rmse, &b.rmse, 1)) << a.index;
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.stalled, b.stalled);
  if (same_run) EXPECT_TRUE(sameBits(&a.milliseconds, &b.milliseconds, 1)) << a.index;
  EXPECT_EQ(a.points, b.points);
  ASSERT_EQ(a.deskew_velocity.has_value(), b.deskew_velocity.has_value()) << a.index;
  if (a.deskew_velocity) EXPECT_TRUE(sameBits(a.deskew_velocity->data(), b.deskew_velocity->data(), 6)) << a.index;
}

SlamConfig pgoConfig(SlamMethod method, bool thread) {
  SlamConfig c = SlamConfig::forMethod(method);
  c.threads = 2;
  c.back_end = thread ? BackEndSchedule::OwnThread : BackEndSchedule::BesideTracking;
  return c;
}

// Naraha's first 76 frames close loops from frame 72 (accepted, optimised online). The back end
// on its own thread applies the frames in the order they were tracked, so its graph and final
// estimate are the synchronous schedule's; an autosave's snapshot mid-run has every frame so far.
TEST(AsyncBackEnd, FinalAnswerEqualsTheSynchronousOne) {
  const auto dir = test::writeSimulatedSequence("async-equal", "naraha", 1, 76);
  const Sequence seq = Sequence::open(dir);
  const SlamResult sync = runSlam(seq, pgoConfig(SlamMethod::PropertyIcpPgo, false));
  std::size_t frames_told = 0, last_corrections = 0;
  std::optional<SlamResult> snapshot;
  SlamSnapshots hooks;
  hooks.frame = [&](const SlamFrameEvent& e) {
    EXPECT_EQ(e.record.index, frames_told);
    EXPECT_EQ(e.poses.size(), frames_told + 1);
    EXPECT_GE(e.corrections, last_corrections);
    last_corrections = e.corrections;
    ++frames_told;
  };
  hooks.due = [&] { return frames_told == 50; };
  hooks.take = [&](const SlamResult& s) { snapshot = s; };
  const auto source = sequenceScanSource(seq, false);
  const SlamConfig async_config = pgoConfig(SlamMethod::PropertyIcpPgo, true);
  const SlamResult async = runSlam(*source, async_config, {}, hooks);

  ASSERT_FALSE(sync.loops.empty());
  EXPECT_EQ(async.loops.size(), sync.loops.size());
  EXPECT_EQ(async.keyframes, sync.keyframes);
  EXPECT_EQ(async.loop_candidates, sync.loop_candidates);
  EXPECT_EQ(async.graph.edges.size(), sync.graph.edges.size());
  EXPECT_EQ(async.optimisations.size(), sync.optimisations.size());
  EXPECT_EQ(frames_told, sync.frames.size());
  expectSamePoses(async.estimate, sync.estimate);
  // The same graph, bit for bit: the gate chained step covariances and the anchors read tracked
  // poses from the back end's journals (all but the newest frames are there), as the synchronous
  // run did from memory.
  ASSERT_EQ(async.graph.poses.size(), sync.graph.poses.size());
  for (std::size_t i = 0; i < sync.graph.poses.size(); ++i)
    EXPECT_TRUE(sameBits(async.graph.poses[i].matrix().data(), sync.graph.poses[i].matrix().data(), 16)) << i;
  for (std::size_t i = 0; i < sync.graph.edges.size() && i < async.graph.edges.size(); ++i) {
    const PoseGraphEdge &a = async.graph.edges[i], &b = sync.graph.edges[i];
    EXPECT_TRUE(a.from == b.from && a.to == b.to && a.kind == b.kind) << "edge " << i;
    EXPECT_TRUE(sameBits(a.T_from_to.matrix().data(), b.T_from_to.matrix().data(), 16)) << "edge " << i;
    EXPECT_TRUE(sameBits(a.information.data(), b.information.data(), 36)) << "edge " << i;
  }
  // Tracking keeps only its newest records (the back end has the run's): the same poses and stamps, bit for bit.
  EXPECT_EQ(async.tracked.stamps, sync.tracked.stamps);
  for (std::size_t i = 0; i < sync.tracked.size(); ++i)
    EXPECT_TRUE(async.tracked.poses[i].matrix() == sync.tracked.poses[i].matrix()) << i;
  EXPECT_GT(async.timings.tracking_s, 0.0);
  // The back end's thread journals all but its newest records: read back whole, bit for bit.
  ASSERT_EQ(async.frames.size(), sync.frames.size());
  for (std::size_t i = 0; i < sync.frames.size(); ++i) expectSameRecord(async.frames[i], sync.frames[i], false);
  ASSERT_TRUE(snapshot.has_value());
  EXPECT_EQ(snapshot->frames.size(), 50u);
  for (std::size_t i = 0; i < 50; ++i) expectSameRecord(snapshot->frames[i], sync.frames[i], false);
  EXPECT_EQ(snapshot->graph.poses.size(), 50u);
  // Its graph has every edge, those in the back end's journal too: the odometry edges are the
  // synchronous run's, bit for bit.
  std::size_t odometry_edges = 0;
  for (const PoseGraphEdge& e : snapshot->graph.edges) {
    if (e.kind != EdgeKind::Odometry) continue;
    ++odometry_edges;
    const auto same = std::find_if(sync.graph.edges.begin(), sync.graph.edges.end(), [&](const PoseGraphEdge& s) {
      return s.kind == EdgeKind::Odometry && s.to == e.to && s.from == e.from &&
             sameBits(s.T_from_to.matrix().data(), e.T_from_to.matrix().data(), 16) &&
             sameBits(s.information.data(), e.information.data(), 36);
    });
    EXPECT_NE(same, sync.graph.edges.end()) << "odometry edge into frame " << e.to;
  }
  EXPECT_EQ(odometry_edges, 49u);
  EXPECT_EQ(snapshot->estimate.size(), 50u);
}

// The journal keeps every field of a record, a reason of any length and an optional deskew
// velocity included; the newest stay in the list, an old one is refused there and read from the
// file, and restoreAll gives the list back whole.
TEST(FrameRecordStore, JournalsOldRecordsAndReadsThemBackBitForBit) {
  std::vector<FrameRecord> made, list;
  pipeline_detail::FrameRecordStore store(list);
  store.push(FrameRecord{});  // before the journal: moved into it when it starts
  made.push_back(FrameRecord{});
  store.journalOlderThan(3);
  for (std::size_t i = 1; i < 40; ++i) {
    FrameRecord r;
    r.index = i;
    r.stamp = 0.1 * static_cast<double>(i) + 1e-17;
    r.T_prev_curr = Eigen::Translation3d(0.1 * i, -0.2, 1.0 / 3.0) * Eigen::AngleAxisd(0.01 * i, Eigen::Vector3d(1, 2, 3).normalized());
    r.covariance = Matrix6d::Random() * 1e-3;
    if (i % 4 == 0) r.guess_covariance = Matrix6d::Random();
    r.icp_used = i % 5 != 0;
    r.status = static_cast<FrameStatus>(i % 5);
    r.fallback_reason = std::string(i * 7, static_cast<char>('a' + i % 26));
    r.fitness = 1.0 / static_cast<double>(i), r.rmse = std::nextafter(0.02, 1.0);
    r.iterations = static_cast<int>(i), r.stalled = i % 3 == 0, r.milliseconds = 1.5 * i, r.points = 1000 + i;
    if (i % 2 == 0) r.deskew_velocity = Vector6d::Random();
    made.push_back(r);
    store.push(r);
  }
  EXPECT_EQ(store.size(), 40u);
  EXPECT_EQ(list.size(), 3u);
  EXPECT_EQ(store.back().index, 39u);
  EXPECT_THROW(store.at(10), std::out_of_range);
  expectSameRecord(store.read(10), made[10]);
  expectSameRecord(store.read(0), made[0]);
  const std::vector<FrameRecord> all = store.all();
  ASSERT_EQ(all.size(), made.size());
  for (std::size_t i = 0; i < made.size(); ++i) expectSameRecord(all[i], made[i]);
  store.restoreAll();
  ASSERT_EQ(list.size(), made.size());
  for (std::size_t i = 0; i < made.size(); ++i) expectSameRecord(list[i], made[i]);
  store.push(made[1]);  // no journal any more
  EXPECT_EQ(list.size(), made.size() + 1);
}

// The journal lives in the temporary folder: one that does not exist is a one-line error.
TEST(FrameRecordStore, AMissingTemporaryFolderIsAnError) {
  const char* before = std::getenv("TMPDIR");
  const std::string saved = before ? before : "";
  ::setenv("TMPDIR", "/nonexistent/hazmap-test", 1);
  std::vector<FrameRecord> list(2);
  pipeline_detail::FrameRecordStore store(list);
  EXPECT_THROW(store.journalOlderThan(1), Error);
  if (before) ::setenv("TMPDIR", saved.c_str(), 1);
  else ::unsetenv("TMPDIR");
  store.push(FrameRecord{});  // still a plain list
  EXPECT_EQ(list.size(), 3u);
  EXPECT_EQ(store.size(), 3u);
}

// The edge journal moves a prefix of the graph's edges (every kind) up to the newest frames'
// odometry edges, only in batches; restored, the graph's edge list is the one never journaled,
// order and bits; a snapshot sees every edge without changing the graph.
TEST(EdgeJournal, APrefixGoesAndComesBackInItsOrderBitForBit) {
  PoseGraph graph;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g;
  for (int i = 0; i < 200; ++i) graph.addNode(Eigen::Isometry3d::Identity());
  auto edge = [&](int from, int to, EdgeKind kind) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(g(rng), g(rng), g(rng));
    Matrix6d A = Matrix6d::Random();
    graph.addEdge(from, to, T, A * A.transpose() + Matrix6d::Identity() * (1.0 + std::abs(g(rng))), kind);
  };
  for (int k = 1; k < 200; ++k) {
    edge(k - 1, k, EdgeKind::Odometry);
    if (k % 10 == 0) edge(k - 10, k, EdgeKind::MapAnchor);
    if (k % 37 == 0) edge(3, k, EdgeKind::Loop);
  }
  const std::vector<PoseGraphEdge> whole = graph.edges;
  auto sameEdges = [&](const std::vector<PoseGraphEdge>& a) {
    ASSERT_EQ(a.size(), whole.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_TRUE(a[i].from == whole[i].from && a[i].to == whole[i].to && a[i].kind == whole[i].kind) << i;
      EXPECT_EQ(std::memcmp(a[i].T_from_to.matrix().data(), whole[i].T_from_to.matrix().data(), 16 * sizeof(double)), 0) << i;
      EXPECT_EQ(std::memcmp(a[i].information.data(), whole[i].information.data(), 36 * sizeof(double)), 0) << i;
    }
  };
  pipeline_detail::EdgeJournal journal;
  journal.journalBefore(graph, 150, 1000);  // fewer than a batch: nothing goes
  EXPECT_EQ(journal.size(), 0u);
  journal.journalBefore(graph, 150, 32);
  ASSERT_GT(journal.size(), 149u);
  ASSERT_FALSE(graph.edges.empty());
  EXPECT_EQ(graph.edges.front().kind, EdgeKind::Odometry);  // the kept part starts at frame 150's edge
  EXPECT_EQ(graph.edges.front().to, 150);
  EXPECT_EQ(journal.size() + graph.edges.size(), whole.size());
  sameEdges(journal.allEdges(graph));
  journal.journalBefore(graph, 190, 32);  // a second block appended behind the first
  sameEdges(journal.allEdges(graph));
  journal.restore(graph);
  EXPECT_EQ(journal.size(), 0u);
  sameEdges(graph.edges);
  journal.journalBefore(graph, 100, 32);  // the journal is reused after a restore
  journal.restore(graph);
  sameEdges(graph.edges);
}

// Tracking never waits for a loop stage: the first keyframe's loop stage is held until the stream
// has ended (every frame tracked, told to the live view, and the source read to its end), which
// could never happen if tracking waited for it, nor for a snapshot (an autosave's) asked for at
// frame 25 meanwhile: that one is delivered once the back end has frame 25, and holds those 25.
// Then the run still finishes every queued frame and the final optimisation, the outputs are
// complete, and the answer is the synchronous one.
TEST(AsyncBackEnd, TrackingNeverWaitsAndAStreamEndingDuringALoopStageWritesCompleteOutputs) {
  const auto dir = test::writeSimulatedSequence("async-slow", "naraha", 1, 40);
  const Sequence seq = Sequence::open(dir);
  WatchedSource source(sequenceScanSource(seq, false));
  std::atomic<std::size_t> frames_told{0};
  bool held = false, released_by_the_end = false;
  SlamSnapshots hooks;
  hooks.frame = [&](const SlamFrameEvent&) { ++frames_told; };
  std::size_t snapshot_asked_at = 0;
  std::optional<SlamResult> snapshot;
  hooks.due = [&] { return frames_told == 25; };
  hooks.taking = [&](std::size_t frames) { snapshot_asked_at = frames; };
  hooks.take = [&](SlamResult s) { snapshot = std::move(s); };
  hooks.loop_stage = [&](std::size_t) {
    if (held) return;
    held = true;  // a deliberately slow verification: until the stream has ended (or 120 s)
    std::unique_lock<std::mutex> lock(source.m);
    released_by_the_end = source.changed.wait_for(lock, std::chrono::seconds(120), [&] { return source.ended; });
  };
  const SlamConfig config = pgoConfig(SlamMethod::IcpPgo, true);
  const SlamResult async = runSlam(source, config, {}, hooks);
  EXPECT_TRUE(held);
  EXPECT_TRUE(released_by_the_end) << "tracking waited for the loop stage";
  EXPECT_EQ(frames_told.load(), 40u);
  EXPECT_EQ(snapshot_asked_at, 25u);
  ASSERT_TRUE(snapshot.has_value());
  EXPECT_EQ(snapshot->frames.size(), 25u);
  EXPECT_EQ(snapshot->graph.poses.size(), 25u);
  EXPECT_EQ(snapshot->estimate.size(), 25u);
  EXPECT_EQ(snapshot->tracked.size(), 25u);
  ASSERT_EQ(async.frames.size(), 40u);
  EXPECT_EQ(async.graph.poses.size(), 40u);
  const SlamResult sync = runSlam(seq, pgoConfig(SlamMethod::IcpPgo, false));
  EXPECT_GT(async.keyframes, 5u);
  EXPECT_EQ(async.keyframes, sync.keyframes);  // every keyframe's loop stage ran, the held one too
  EXPECT_EQ(async.anchors.size(), sync.anchors.size());
  EXPECT_EQ(async.graph.edges.size(), sync.graph.edges.size());

  const auto out = dir.parent_path() / (dir.filename().string() + "-out");
  OutputConfig outputs;
  outputs.write_viewer = false;
  writeRunOutputs(seq, async, config, outputs, out);
  std::ifstream kitti(out / "trajectory.kitti");
  std::size_t lines = 0;
  for (std::string line; std::getline(kitti, line);) lines += !line.empty();
  EXPECT_EQ(lines, 40u);
  std::ifstream g2o(out / "graph.g2o");
  std::size_t vertices = 0;
  for (std::string line; std::getline(g2o, line);) vertices += line.rfind("VERTEX_SE3", 0) == 0;
  EXPECT_EQ(vertices, 40u);
  expectSamePoses(async.estimate, sync.estimate);
}

// The back end gives way to tracking (back_end_thread.cpp, kMaxYieldLag): while tracking works on
// a scan (here its frame hook holds it, keyframes queued behind it) the back end starts no loop
// stage; held past the back end's patience (5 s after the frame in hand was queued) it goes on.
TEST(AsyncBackEnd, GivesWayWhileTrackingWorksOnAScanButNotForever) {
  const auto dir = test::writeSimulatedSequence("async-give-way", "naraha", 1, 30);
  const Sequence seq = Sequence::open(dir);
  const auto source = sequenceScanSource(seq, false);
  std::atomic<std::size_t> loop_stages{0};
  std::size_t held_at = 0, before = 0, after_1s = 0, after_7s = 0, backlog = 0;
  SlamSnapshots hooks;
  hooks.loop_stage = [&](std::size_t) {  // the first stages slow (no yield point in a sleep): frames queue up
    if (++loop_stages <= 8) std::this_thread::sleep_for(std::chrono::milliseconds(40));
  };
  hooks.frame = [&](const SlamFrameEvent& e) {
    if (held_at != 0 || e.back_end_backlog < 4) return;
    held_at = e.record.index;
    backlog = e.back_end_backlog;
    before = loop_stages;
    std::this_thread::sleep_for(std::chrono::seconds(1));
    after_1s = loop_stages;
    std::this_thread::sleep_for(std::chrono::seconds(6));
    after_7s = loop_stages;
  };
  const SlamResult async = runSlam(*source, pgoConfig(SlamMethod::IcpPgo, true), {}, hooks);
  ASSERT_GT(held_at, 0u) << "the back end never had 4 frames queued";
  EXPECT_EQ(after_1s, before) << "a loop stage started while tracking held frame " << held_at;
  EXPECT_GT(after_7s, after_1s) << "the back end waited for tracking beyond its patience (" << backlog << " queued)";
  EXPECT_EQ(loop_stages.load(), async.keyframes);
  EXPECT_EQ(async.graph.poses.size(), 30u);
}

TEST(AsyncBackEnd, QueueBoundMustBePositive) {
  SlamConfig c = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  c.applySetting("slam.back_end=own-thread");
  EXPECT_EQ(c.back_end, BackEndSchedule::OwnThread);
  EXPECT_THROW(c.applySetting("slam.back_end=sideways"), Error);
  EXPECT_THROW(c.applySetting("slam.back_end_queue_mb=0"), Error);
}

TEST(FrameLatency, QuantilesOfTheSamples) {
  FrameLatency l;
  EXPECT_EQ(l.quantileMs(0.99), 0.0);
  for (int i = 1; i <= 100; ++i) l.add(i * 1e-3);  // 1 .. 100 ms
  l.add(-1.0);                                      // clock step back: counted as 0
  l.add(std::nan(""));                              // ignored
  EXPECT_EQ(l.count(), 101u);
  EXPECT_NEAR(l.quantileMs(0.5), 50.0, 0.15);
  EXPECT_NEAR(l.quantileMs(0.99), 99.0, 0.15);
  EXPECT_NEAR(l.maxMs(), 100.0, 1e-9);
  l.add(60.0);  // beyond the histogram: the largest still exact
  EXPECT_NEAR(l.maxMs(), 60000.0, 1e-6);
  EXPECT_LE(l.quantileMs(1.0), 60000.0);
}

TEST(FrameLatency, NewestPointTime) {
  LabeledCloud c;
  EXPECT_EQ(newestPointTime(c), 0.0);
  c.points = {Eigen::Vector3f::Zero(), Eigen::Vector3f::Ones()};
  c.classes = {0, 0};
  c.timestamps = {5.0, 4.0};
  EXPECT_EQ(newestPointTime(c), 5.0);
}

}  // namespace
}  // namespace hazmap
