// Property ICP against plain ICP on simulated sequences where geometry alone is weak (issue 4's
// corridor and tanks checks), and under wrong labels (the label-noise sweep): labels must help
// where the geometry is degenerate and, when they are noise, never make tracking much worse.
#include <gtest/gtest.h>

#include <cstdio>

#include "hazmap/odometry/odometry.hpp"
#include "hazmap/sim/simulator.hpp"

using namespace hazmap;

namespace {

struct TrackRun {
  double mean_error = 0.0;     ///< m, mean |t_est − t_true| (both start at the identity)
  double labels_used = 0.0;    ///< share of registrations that used the labels
};

// Frame-to-map odometry with the library defaults and the wheel-odometry guess, as `hazmap run`.
TrackRun track(const sim::Simulator& sim, bool use_classes) {
  OdometryConfig cfg = OdometryConfig::defaults();
  cfg.registration.use_classes = use_classes;
  Odometry odo(sim.classTable(), cfg);
  const auto& wheel = sim.odometry();
  TrackRun run;
  std::size_t registered = 0, with_labels = 0;
  for (std::size_t i = 0; i < sim.frames(); ++i) {
    std::optional<Eigen::Isometry3d> inc;
    if (i > 0) inc = wheel[i - 1].inverse() * wheel[i];
    const OdometryFrame& f = odo.addFrame(sim.scan(i), inc);
    run.mean_error += (f.pose.translation() - sim.groundTruth()[i].translation()).norm();
    if (i > 0) {
      ++registered;
      with_labels += f.registration.labels_used;
    }
  }
  run.mean_error /= static_cast<double>(sim.frames());
  run.labels_used = registered ? static_cast<double>(with_labels) / static_cast<double>(registered) : 0.0;
  return run;
}

sim::SimulatorConfig scenario(const std::string& name, double wrong_labels) {
  sim::SimulatorConfig c;
  c.scenario = name;
  c.seed = 3;
  if (wrong_labels >= 0.0) {  // < 0: the simulator's specified defaults
    c.labels.false_property = wrong_labels;
    c.labels.property_dropout = wrong_labels;
  }
  return c;
}

}  // namespace

TEST(PropertyVsPlain, CorridorLabelsHoldTheAxis) {
  const sim::Simulator sim(scenario("corridor", -1.0));
  const TrackRun plain = track(sim, false), prop = track(sim, true);
  std::printf("corridor (default label noise): plain %.3f m, property %.3f m, labels used %.0f%%\n",
              plain.mean_error, prop.mean_error, 100.0 * prop.labels_used);
  // 0.6x until 2026-12-02; then plain ICP stopped refusing right answers as "diverged" (ICP's
  // correction measured in the sensor frame, issue 19): plain 4.02 -> 0.89 m, property 0.534 -> 0.541 m
  // (0.61x). Both are chaotic runs: the bound asks for a clear win, not for the last measured ratio.
  EXPECT_LT(prop.mean_error, 0.8 * plain.mean_error);
  EXPECT_GT(prop.labels_used, 0.9);
}

TEST(PropertyVsPlain, TanksNotWorse) {
  const sim::Simulator sim(scenario("tanks", -1.0));
  const TrackRun plain = track(sim, false), prop = track(sim, true);
  std::printf("tanks (default label noise): plain %.3f m, property %.3f m\n", plain.mean_error, prop.mean_error);
  EXPECT_LT(prop.mean_error, 1.1 * plain.mean_error + 0.02);
}

// An open field of identical tanks seen from 0.5 m: level pairs (the floor) are ~80 % of ICP's
// pairs. Until 2026-12-06 their near-zero residuals set the robust scale for every ordinary pair and
// the tanks' pairs were rejected as outliers, and the floor's weight made x, y and yaw look
// degenerate: tracking kept the wheels' guess (property ICP 0.70 / 0.92 m mean error on seeds 2 / 3,
// plain ICP 1.06 / 1.20 m; the wheels 1.10 / 1.50 m). Now the tanks hold the pose (property ICP
// 0.062 / 0.055 m, plain 0.043 / 0.041 m).
class OpenField : public ::testing::TestWithParam<unsigned> {};

TEST_P(OpenField, TanksHoldThePoseWhereTheWheelsSlip) {
  sim::SimulatorConfig c;
  c.scenario = "tanks";
  c.seed = GetParam();
  const sim::Simulator sim(c);
  double wheels = 0.0;
  for (std::size_t i = 0; i < sim.frames(); ++i)
    wheels += (sim.odometry()[i].translation() - sim.groundTruth()[i].translation()).norm();
  wheels /= static_cast<double>(sim.frames());
  const TrackRun plain = track(sim, false), prop = track(sim, true);
  std::printf("tanks seed %u: wheels %.3f m, plain ICP %.3f m, property ICP %.3f m\n", c.seed, wheels,
              plain.mean_error, prop.mean_error);
  EXPECT_LT(plain.mean_error, 0.15);
  EXPECT_LT(prop.mean_error, 0.15);
}

INSTANTIATE_TEST_SUITE_P(Seeds, OpenField, ::testing::Values(2u, 3u));

class LabelNoiseSweep : public ::testing::TestWithParam<double> {};

// p of the property points lose their class and p of the others get a random property class.
TEST_P(LabelNoiseSweep, CorridorNeverMuchWorseThanPlain) {
  const double p = GetParam();
  const sim::Simulator sim(scenario("corridor", p));
  const TrackRun plain = track(sim, false), prop = track(sim, true);
  std::printf("corridor, %.0f%% wrong labels: plain %.3f m, property %.3f m, labels used %.0f%%\n", 100.0 * p,
              plain.mean_error, prop.mean_error, 100.0 * prop.labels_used);
  EXPECT_LT(prop.mean_error, 1.1 * plain.mean_error + 0.02);
  if (p >= 0.1) EXPECT_LT(prop.labels_used, 0.2);  // the gate sees the labels are noise
}

INSTANTIATE_TEST_SUITE_P(Sweep, LabelNoiseSweep, ::testing::Values(0.0, 0.1, 0.3));
