// The loop-search schedule (SlamConfig::loop_search_every, loop_pause_after_accept): which
// keyframes the back end searches for loops, alone and inside a run.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <optional>
#include <vector>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/eval/trajectory_metrics.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "pipeline/loop_schedule.hpp"
#include "test_helpers.hpp"

using namespace hazmap;

namespace {

std::vector<std::size_t> searched(LoopSchedule& s, std::size_t n, const std::vector<std::size_t>& accepted) {
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k < n; ++k) {
    if (!s.searches(k)) continue;
    out.push_back(k);
    if (std::find(accepted.begin(), accepted.end(), k) != accepted.end()) s.accepted(k);
  }
  return out;
}

}  // namespace

TEST(LoopSchedule, EveryKeyframeByDefault) {
  LoopSchedule s(1, 0);
  EXPECT_EQ(searched(s, 6, {1, 2}), (std::vector<std::size_t>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(s.skipped(), 0u);
}

TEST(LoopSchedule, EveryNthKeyframe) {
  LoopSchedule s(3, 0);
  EXPECT_EQ(searched(s, 10, {3}), (std::vector<std::size_t>{0, 3, 6, 9}));
  EXPECT_EQ(s.skipped(), 6u);
}

TEST(LoopSchedule, PauseAfterAnAcceptedLoop) {
  LoopSchedule s(1, 2);
  // 2 accepted: 3, 4 skipped; 5 accepted: 6, 7 skipped.
  EXPECT_EQ(searched(s, 10, {2, 5}), (std::vector<std::size_t>{0, 1, 2, 5, 8, 9}));
  // Both: after the pause the stride decides (4 accepted: pause 1 skips 5, 6 is on stride;
  // pause 2 skips 5 and 6, and 7 is off stride).
  LoopSchedule both(2, 1);
  EXPECT_EQ(searched(both, 10, {4}), (std::vector<std::size_t>{0, 2, 4, 6, 8}));
  LoopSchedule longer(2, 2);
  EXPECT_EQ(searched(longer, 10, {4}), (std::vector<std::size_t>{0, 2, 4, 8}));
}

// Up to 4,000 nodes every accepted loop is solved at once (Table 2's runs have 100–163 frames);
// beyond, the keyframes between solves grow with the graph so that nodes solved per keyframe stay
// at most 4,000 (the hour on the closed route: ~37,000 frames, a solve every 10 keyframes).
TEST(LoopSchedule, SolvesGetRarerAsTheGraphGrowsAndTheirShareStaysBounded) {
  EXPECT_EQ(keyframesBetweenSolves(1), 1u);
  EXPECT_EQ(keyframesBetweenSolves(kNodesSolvedPerKeyframe), 1u);
  EXPECT_EQ(keyframesBetweenSolves(kNodesSolvedPerKeyframe + 1), 2u);
  EXPECT_EQ(keyframesBetweenSolves(37000), 10u);
  for (std::size_t nodes = 1; nodes < 200000; nodes += 997) {
    const std::size_t every = keyframesBetweenSolves(nodes);
    EXPECT_LE(double(nodes) / double(every), double(kNodesSolvedPerKeyframe)) << nodes;
    EXPECT_GE(keyframesBetweenSolves(nodes + 1), every) << nodes;  // never more often as it grows
  }
}

TEST(LoopSchedule, ARunSearchesOnlyTheScheduledKeyframes) {
  const auto dir = test::writeSimulatedSequence("loop-schedule", "corridor", 3, 12);
  const Sequence seq = Sequence::open(dir);
  SlamConfig every = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  every.loop_search_every = 1;
  every.loop_pause_after_accept = 0;
  const SlamResult all = runSlam(seq, every);
  EXPECT_EQ(all.keyframes_searched, all.keyframes);
  SlamConfig third = every;
  third.loop_search_every = 3;
  const SlamResult r = runSlam(seq, third);
  ASSERT_GT(r.keyframes, 3u);
  EXPECT_EQ(r.keyframes, all.keyframes);  // tracking is untouched
  EXPECT_EQ(r.keyframes_searched, (r.keyframes + 2) / 3);
  EXPECT_EQ(r.tracked.poses.size(), all.tracked.poses.size());
  for (std::size_t i = 0; i < r.tracked.poses.size(); ++i)
    EXPECT_TRUE(r.tracked.poses[i].isApprox(all.tracked.poses[i], 0.0)) << "frame " << i;
  // Bad settings name the key.
  SlamConfig bad = every;
  EXPECT_THROW(bad.applySetting("slam.loop_search_every=0"), Error);
}

// The loop stage beside tracking (SlamConfig::back_end beside-tracking) is a pure speed change: the
// same run with it off gives the same trajectory, graph and loop decisions bit for bit. Naraha's
// first 45 frames hold loop candidates that are verified and rejected (low fitness, the gate).
TEST(LoopsBesideTracking, SameResultsBitForBit) {
  const auto dir = test::writeSimulatedSequence("loops-beside", "naraha", 1, 45);
  const Sequence seq = Sequence::open(dir);
  SlamConfig beside = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  beside.threads = 2;
  beside.back_end = BackEndSchedule::BesideTracking;
  SlamConfig after = beside;
  after.back_end = BackEndSchedule::AfterFrame;
  const SlamResult a = runSlam(seq, beside), b = runSlam(seq, after);
  EXPECT_GT(a.loop_candidates, 0u);
  EXPECT_EQ(a.loop_candidates, b.loop_candidates);
  EXPECT_EQ(a.keyframes, b.keyframes);
  EXPECT_EQ(a.loops.size(), b.loops.size());
  ASSERT_EQ(a.rejected_loops.size(), b.rejected_loops.size());
  for (std::size_t i = 0; i < a.rejected_loops.size(); ++i) {
    EXPECT_EQ(a.rejected_loops[i].to_frame, b.rejected_loops[i].to_frame);
    EXPECT_EQ(a.rejected_loops[i].detail, b.rejected_loops[i].detail);
  }
  ASSERT_EQ(a.graph.edges.size(), b.graph.edges.size());
  for (std::size_t i = 0; i < a.graph.edges.size(); ++i)
    EXPECT_TRUE(a.graph.edges[i].information == b.graph.edges[i].information) << "edge " << i;
  ASSERT_EQ(a.estimate.poses.size(), b.estimate.poses.size());
  for (std::size_t i = 0; i < a.estimate.poses.size(); ++i)
    EXPECT_TRUE(a.estimate.poses[i].matrix() == b.estimate.poses[i].matrix()) << "frame " << i;
}

// A long mission's online solves are of the keyframes' graph (SlamConfig::online_keyframe_graph_after;
// default 4,000 frames, here from frame 40 so that a short scene runs them): naraha's route scanned
// every 0.5 m closes loops from frame ~145, each solved online on the keyframes' graph, then the end
// solves the whole graph. Its answer is the whole-graph run's within millimetres, as far from the
// truth, with the same loops; only the online estimates in between differ.
TEST(LoopSchedule, OnlineSolvesOfTheKeyframesGraphEndWhereTheWholeGraphsDo) {
  sim::SimulatorConfig scene;  // naraha's route scanned every 0.5 m: a keyframe every other frame
  scene.robot.frame_distance = 0.5;
  scene.max_frames = 220;
  const auto dir = test::scratchDir() / "seq";
  sim::writeSimulation(scene, dir, /*overwrite=*/true);
  const Sequence seq = Sequence::open(dir);
  SlamConfig whole = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  whole.threads = 2;
  whole.online_keyframe_graph_after = 0;
  SlamConfig keyframes = whole;
  keyframes.online_keyframe_graph_after = 40;
  // Each run's online estimate at frame 200 (after the loops' online solves), and its end.
  const auto run = [&](const SlamConfig& config, std::optional<SlamResult>& at_200) {
    std::size_t frames = 0;
    SlamSnapshots hooks;
    hooks.frame = [&](const SlamFrameEvent&) { ++frames; };
    hooks.due = [&] { return frames == 200; };
    hooks.take = [&](SlamResult s) { at_200 = std::move(s); };
    const auto source = sequenceScanSource(seq, false);
    return runSlam(*source, config, {}, hooks);
  };
  std::optional<SlamResult> online_a, online_b;
  const SlamResult a = run(whole, online_a), b = run(keyframes, online_b);
  ASSERT_TRUE(online_a && online_b);
  ASSERT_EQ(online_a->estimate.size(), 200u);
  ASSERT_EQ(online_b->estimate.size(), 200u);
  double online_apart = 0;
  for (std::size_t i = 0; i < 200; ++i)
    online_apart = std::max(online_apart, translationNorm(online_a->estimate.poses[i].inverse() * online_b->estimate.poses[i]));
  std::cout << "online estimates at frame 200: " << 1e3 * online_apart << " mm apart\n";
  EXPECT_GT(online_apart, 1e-9);  // the keyframes' graph was solved online
  EXPECT_LT(online_apart, 0.01);
  ASSERT_GT(a.optimisations.size(), 1u);  // online solves, then the end's
  EXPECT_EQ(b.optimisations.size(), a.optimisations.size());
  EXPECT_EQ(b.loops.size(), a.loops.size());
  ASSERT_EQ(a.estimate.size(), b.estimate.size());
  double farthest = 0, turned = 0;
  for (std::size_t i = 0; i < a.estimate.size(); ++i) {
    const Eigen::Isometry3d d = a.estimate.poses[i].inverse() * b.estimate.poses[i];
    farthest = std::max(farthest, translationNorm(d));
    turned = std::max(turned, rotationAngle(d));
  }
  const double ate_a = computeApe(*seq.groundTruth(), a.estimate, Alignment::None).translation.rmse;
  const double ate_b = computeApe(*seq.groundTruth(), b.estimate, Alignment::None).translation.rmse;
  std::cout << "keyframes' graph online vs whole graph: " << 1e3 * farthest << " mm, " << turned * 180 / M_PI
            << " deg apart; ATE " << ate_b << " / " << ate_a << " m\n";
  EXPECT_LT(farthest, 0.002);
  EXPECT_LT(turned * 180 / M_PI, 0.02);
  EXPECT_LT(ate_b, ate_a + 0.002);
  EXPECT_THROW(keyframes.applySetting("slam.online_keyframe_graph_after=-1"), Error);
}
