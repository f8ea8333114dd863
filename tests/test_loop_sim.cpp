// Loop closure on the simulator's naraha scene (issue 3) with heavily drifting odometry: the
// property-landmark constellations find the revisit of the corridor, where the distance-based
// search on the odometry estimate does not. Only the frames that matter are simulated (the first
// corridor pass and the revisit), so the test stays fast.
#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include "hazmap/core/se3.hpp"
#include "hazmap/loop/loop_closure.hpp"
#include "hazmap/sim/simulator.hpp"

using namespace hazmap;

namespace {

struct SimLoopData {
  std::vector<std::size_t> frames;  ///< simulator frame of each keyframe
  std::vector<LabeledCloud> clouds;
  PoseList truth, odometry;
  ClassTable table;
  std::size_t revisit_begin = 0;  ///< first keyframe of the revisit
};

// naraha with the odometry noise of a crawler on a slippery floor: 4× the yaw noise, 3× the
// slips of the spec defaults (issue 3), so the estimate is metres off at the revisit.
const SimLoopData& naraha() {
  static const SimLoopData data = [] {
    sim::SimulatorConfig c;
    c.scenario = "naraha";
    c.seed = 2;
    c.odometry.yaw_sigma_deg = 1.0;
    c.odometry.slip_probability = 0.25;
    c.odometry.forward_scale_sigma = 0.08;
    const sim::Simulator sim(c);
    SimLoopData d;
    d.table = sim.classTable();
    const std::size_t n = sim.frames();
    for (std::size_t f = 0; f <= 30; ++f) d.frames.push_back(f);
    d.revisit_begin = d.frames.size();
    for (std::size_t f = n - 28; f < n; ++f) d.frames.push_back(f);
    d.clouds.resize(d.frames.size());
    tbb::parallel_for(std::size_t{0}, d.frames.size(), [&](std::size_t k) { d.clouds[k] = sim.scan(d.frames[k]); });
    for (std::size_t f : d.frames) {
      d.truth.push_back(sim.groundTruth()[f]);
      d.odometry.push_back(sim.odometry()[f]);
    }
    return d;
  }();
  return data;
}

bool guessIsTrue(const LoopCandidate& c, const PoseList& truth) {
  const Eigen::Isometry3d err = (truth[c.match].inverse() * truth[c.query]).inverse() * c.initial_guess;
  return translationNorm(err) < 1.0 && rotationAngle(err) < 0.1;
}

TEST(LoopSim, ConstellationsFindTheRevisitThatTheDistanceSearchMisses) {
  const SimLoopData& d = naraha();
  const std::size_t n = d.frames.size();
  // The scenario is meaningful only if the odometry is farther off than the search radius.
  LoopClosureConfig cfg;
  double min_drift = 1e9;
  for (std::size_t k = d.revisit_begin; k < n; ++k)
    min_drift = std::min(min_drift, (d.odometry[k].translation() - d.truth[k].translation()).norm());
  ASSERT_GT(min_drift, cfg.candidates.search_radius + 1.0);

  std::vector<std::vector<PropertyLandmark>> lms;
  for (const auto& c : d.clouds) lms.push_back(extractLandmarks(c, d.table, cfg.landmarks));
  std::vector<std::vector<PropertyLandmark>> places(n);
  for (std::size_t k = 0; k < n; ++k) {
    // Windows never straddle the jump between the two passes.
    const std::size_t lo = k >= d.revisit_begin ? d.revisit_begin : 0;
    const std::size_t first = std::max(lo, k + 1 >= cfg.landmark_window ? k + 1 - cfg.landmark_window : 0);
    places[k] = mergeLandmarks(lms, d.odometry, first, k, k, cfg.landmark_merge_distance);
  }

  std::size_t constellation_true = 0, constellation_false = 0, queries_closed = 0;
  std::size_t distance_candidates = 0, distance_true = 0;
  for (std::size_t q = d.revisit_begin; q < n; ++q) {
    const auto cands = findConstellationCandidates(q, places, cfg.candidates);
    if (!cands.empty() && guessIsTrue(cands.front(), d.truth)) ++queries_closed;
    for (const auto& c : cands) (guessIsTrue(c, d.truth) ? constellation_true : constellation_false)++;
    for (const auto& c : findDistanceCandidates(q, d.odometry, cfg.candidates)) {
      ++distance_candidates;
      distance_true += guessIsTrue(c, d.truth);
    }
  }
  std::cout << "revisit queries " << n - d.revisit_begin << ": constellation top-1 true for "
            << queries_closed << ", candidates " << constellation_true << " true / "
            << constellation_false << " false; distance candidates " << distance_candidates
            << " (" << distance_true << " with a usable guess); min odometry drift " << min_drift
            << " m\n";
  EXPECT_GE(queries_closed, (n - d.revisit_begin) / 2);
  EXPECT_GT(constellation_true, 2 * constellation_false);
  EXPECT_EQ(distance_true, 0u);
}

}  // namespace
