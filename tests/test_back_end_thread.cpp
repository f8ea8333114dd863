// The asynchronous back end (issue 33 part 3, SlamConfig::back_end own-thread): the same final
// answer as the synchronous schedule, tracking that never waits for a loop stage, and a stream
// that ends while a loop stage is in flight still gives complete outputs.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <mutex>
#include <string>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/pipeline/frame_latency.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "hazmap/sources/forwarding_source.hpp"
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
  // Tracking keeps only its newest records (the back end has the run's): the same poses and stamps, bit for bit.
  EXPECT_EQ(async.tracked.stamps, sync.tracked.stamps);
  for (std::size_t i = 0; i < sync.tracked.size(); ++i)
    EXPECT_TRUE(async.tracked.poses[i].matrix() == sync.tracked.poses[i].matrix()) << i;
  EXPECT_GT(async.timings.tracking_s, 0.0);
  ASSERT_TRUE(snapshot.has_value());
  EXPECT_EQ(snapshot->frames.size(), 50u);
  EXPECT_EQ(snapshot->graph.poses.size(), 50u);
  EXPECT_EQ(snapshot->estimate.size(), 50u);
}

// Tracking never waits for a loop stage: the first keyframe's loop stage is held until the stream
// has ended (every frame tracked, told to the live view, and the source read to its end), which
// could never happen if tracking waited for it. Then the run still finishes every queued frame and
// the final optimisation, the outputs are complete, and the answer is the synchronous one.
TEST(AsyncBackEnd, TrackingNeverWaitsAndAStreamEndingDuringALoopStageWritesCompleteOutputs) {
  const auto dir = test::writeSimulatedSequence("async-slow", "naraha", 1, 40);
  const Sequence seq = Sequence::open(dir);
  WatchedSource source(sequenceScanSource(seq, false));
  std::atomic<std::size_t> frames_told{0};
  bool held = false, released_by_the_end = false;
  SlamSnapshots hooks;
  hooks.frame = [&](const SlamFrameEvent&) { ++frames_told; };
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
