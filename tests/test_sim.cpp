// Simulator library: VLP-16 geometry, ranges, labels and label noise, odometry noise statistics,
// route sampling, the built-in scenes, determinism, config parsing and validation.
#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <numeric>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/sim/mesh_builder.hpp"
#include "hazmap/sim/simulator.hpp"
#include "test_helpers.hpp"

using namespace hazmap;
using namespace hazmap::sim;
using hazmap::test::errorOf;

namespace {

constexpr double kDeg = M_PI / 180.0;

struct Stats {
  double mean = 0.0, std = 0.0;
  std::size_t n = 0;
};
Stats stats(const std::vector<double>& v) {
  Stats s;
  s.n = v.size();
  if (v.empty()) return s;
  s.mean = std::accumulate(v.begin(), v.end(), 0.0) / v.size();
  double ss = 0.0;
  for (double x : v) ss += (x - s.mean) * (x - s.mean);
  s.std = std::sqrt(ss / v.size());
  return s;
}

/// A wall facing -x at x = 10 (y, z within ±50 m), nothing else.
Scene wallScene() {
  Scene s;
  s.name = "wall";
  MeshBuilder mb(s.mesh);
  mb.box({10, -50, -50}, {11, 50, 50});
  s.route.waypoints = {{0, 0}, {1, 0}};
  s.route.corner_radius = 0.0;
  s.route.floor_z = -0.5;  // sensor at z = 0
  return s;
}

/// A 20 m x 20 m room, 4 m high, with a heat box region on one wall and a water patch.
Scene roomScene() {
  Scene s;
  s.name = "room";
  MeshBuilder mb(s.mesh);
  mb.floorRect(-10, -10, 10, 10, 0.0);
  mb.box({-10.5, -10, 0}, {-10, 10, 4});
  mb.box({10, -10, 0}, {10.5, 10, 4});
  mb.box({-10, -10.5, 0}, {10, -10, 4});
  mb.box({-10, 10, 0}, {10, 10.5, 4});
  s.regions.push_back(PropertyRegion::box("hot wall", 1, {9.9, -3, 0.0}, {10.1, 3, 3.0}));
  s.regions.push_back(PropertyRegion::prism("puddle", 2, {{-4, -2}, {-1, -3}, {-1, 1}, {-3, 2}}, -0.05, 0.05));
  s.route.waypoints = {{0, 0}, {4, 0}};
  s.labelTriangles();
  return s;
}

SimulatorConfig quietConfig() {
  SimulatorConfig c;
  c.sensor.range_noise_sigma = 0.0;
  c.sensor.dropout_probability = 0.0;
  c.labels.property_dropout = 0.0;
  c.labels.false_property = 0.0;
  return c;
}

}  // namespace

// ---- sensor geometry -------------------------------------------------------------------------

TEST(SimLidar, Vlp16ChannelsAndColumns) {
  const LidarConfig lidar;
  const auto el = lidar.elevationsDeg();
  ASSERT_EQ(el.size(), 16u);
  for (int k = 0; k < 16; ++k) EXPECT_NEAR(el[k], -15.0 + 2.0 * k, 1e-12);
  EXPECT_EQ(lidar.columns, 1800);
  EXPECT_NEAR(lidar.azimuthStepDeg(), 0.2, 1e-12);
  EXPECT_DOUBLE_EQ(lidar.min_range, 0.4);
  EXPECT_DOUBLE_EQ(lidar.max_range, 100.0);
  EXPECT_DOUBLE_EQ(lidar.range_noise_sigma, 0.03);
  EXPECT_DOUBLE_EQ(lidar.dropout_probability, 0.01);
  EXPECT_DOUBLE_EQ(lidar.mount_height, 0.5);
  const auto dirs = lidar.rayDirections();
  ASSERT_EQ(dirs.size(), 28800u);
  // Column 450 = azimuth 90° (+y), channel 7 = -1°.
  const Eigen::Vector3f d = dirs[450 * 16 + 7];
  EXPECT_NEAR(d.x(), 0.0, 1e-6);
  EXPECT_NEAR(d.y(), std::cos(1.0 * kDeg), 1e-6);
  EXPECT_NEAR(d.z(), -std::sin(1.0 * kDeg), 1e-6);
  for (const auto& v : dirs) EXPECT_NEAR(v.norm(), 1.0f, 1e-6f);
}

TEST(SimLidar, RayAgainstKnownWallIsExact) {
  const Scene s = wallScene();
  const RayCaster caster(s.mesh);
  const RayHit h = caster.cast(Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitX());
  ASSERT_TRUE(h.hit());
  EXPECT_NEAR(h.distance, 10.0f, 1e-4f);
  EXPECT_NEAR(h.normal.x(), -1.0f, 1e-6f);
  // Oblique ray: 10 / cos(30°).
  const Eigen::Vector3f d(std::cos(30 * kDeg), std::sin(30 * kDeg), 0.0f);
  EXPECT_NEAR(caster.cast(Eigen::Vector3f::Zero(), d).distance, 10.0 / std::cos(30 * kDeg), 1e-4);
  // Facing away: no hit; beyond t_far: no hit.
  EXPECT_FALSE(caster.cast(Eigen::Vector3f::Zero(), -Eigen::Vector3f::UnitX()).hit());
  EXPECT_FALSE(caster.cast(Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitX(), 0.0f, 9.0f).hit());
}

TEST(SimLidar, WallRangesWithinNoiseAndDropoutRate) {
  SimulatorConfig c;  // default noise: σ = 0.03 m, 1 % dropouts
  c.labels.false_property = 0.0;
  const Simulator sim(c, wallScene(), ClassTable::defaults());
  std::vector<double> residual;
  std::size_t returned = 0, expected_hits = 0;
  const Simulator quiet(quietConfig(), wallScene(), ClassTable::defaults());
  for (std::size_t f = 0; f < 2; ++f) {
    expected_hits += quiet.scan(f).size();
    const LabeledCloud scan = sim.scan(f);
    const Eigen::Isometry3d T = sim.worldPoses()[f];
    returned += scan.size();
    for (const auto& p : scan.points) {
      // True range along this point's ray to the plane x = 10 in the world.
      const Eigen::Vector3d dir_w = T.linear() * p.cast<double>().normalized();
      const double expected = (10.0 - T.translation().x()) / dir_w.x();
      residual.push_back(p.cast<double>().norm() - expected);
    }
  }
  const Stats s = stats(residual);
  EXPECT_NEAR(s.mean, 0.0, 0.002);
  EXPECT_NEAR(s.std, 0.03, 0.0015);
  double max_abs = 0.0;
  for (double r : residual) max_abs = std::max(max_abs, std::abs(r));
  EXPECT_LT(max_abs, 6 * 0.03);
  const double drop = 1.0 - static_cast<double>(returned) / expected_hits;
  EXPECT_NEAR(drop, 0.01, 0.003);  // ~30k rays: binomial σ ≈ 0.0006
}

TEST(SimLidar, MinAndMaxRangeDiscardReturns) {
  SimulatorConfig c = quietConfig();
  c.sensor.max_range = 10.5;  // only the central part of the wall is in range
  const Simulator sim(c, wallScene(), ClassTable::defaults());
  const LabeledCloud scan = sim.scan(0);
  ASSERT_FALSE(scan.empty());
  for (const auto& p : scan.points) {
    EXPECT_LE(p.norm(), 10.5f + 1e-4f);
    EXPECT_GE(p.norm(), 10.0f - 1e-4f);
  }
}

// ---- classes ---------------------------------------------------------------------------------

TEST(SimLabels, PointsInsideRegionsCarryTheirClassOutsideDoNot) {
  const Scene room = roomScene();
  const Simulator sim(quietConfig(), room, ClassTable::defaults());
  std::size_t heat = 0, water = 0, none = 0;
  for (std::size_t f = 0; f < sim.frames(); ++f) {
    const LabeledCloud scan = sim.scan(f);
    const Eigen::Isometry3d T = sim.worldPoses()[f];
    for (std::size_t i = 0; i < scan.size(); ++i) {
      const Eigen::Vector3d w = T * scan.points[i].cast<double>();
      // Skip points within 1 cm of a region boundary (float rounding decides those).
      bool near_boundary = false;
      for (const Eigen::Vector3d& d : {Eigen::Vector3d(0.01, 0, 0), Eigen::Vector3d(0, 0.01, 0),
                                       Eigen::Vector3d(0, 0, 0.01)})
        near_boundary = near_boundary || room.classAt(w + d) != room.classAt(w - d);
      if (near_boundary) continue;
      ASSERT_EQ(scan.classes[i], room.classAt(w)) << "point " << w.transpose();
      heat += scan.classes[i] == 1;
      water += scan.classes[i] == 2;
      none += scan.classes[i] == 0;
    }
  }
  EXPECT_GT(heat, 500u);
  EXPECT_GT(water, 100u);
  EXPECT_GT(none, 10000u);
}

TEST(SimLabels, LabelNoiseRatesMatchConfig) {
  SimulatorConfig c;  // default label noise: 3 % of property points lose it, 0.5 % gain one
  const Scene room = roomScene();
  const Simulator sim(c, room, ClassTable::defaults());
  std::size_t property = 0, lost = 0, other = 0, gained = 0;
  std::vector<std::size_t> gained_by_class(4, 0);
  for (std::size_t f = 0; f < sim.frames(); ++f) {
    std::vector<ClassId> truth;
    const LabeledCloud scan = sim.scan(f, &truth);
    ASSERT_EQ(truth.size(), scan.size());
    for (std::size_t i = 0; i < scan.size(); ++i) {
      if (truth[i] != 0) {
        ++property;
        if (scan.classes[i] == 0) ++lost;
        else EXPECT_EQ(scan.classes[i], truth[i]);
      } else {
        ++other;
        if (scan.classes[i] != 0) {
          ++gained;
          ++gained_by_class.at(scan.classes[i]);
        }
      }
    }
  }
  ASSERT_GT(property, 3000u);
  const double lost_rate = static_cast<double>(lost) / property;
  const double gained_rate = static_cast<double>(gained) / other;
  const double lost_sigma = std::sqrt(0.03 * 0.97 / property);
  const double gained_sigma = std::sqrt(0.005 * 0.995 / other);
  EXPECT_NEAR(lost_rate, 0.03, 4 * lost_sigma);
  EXPECT_NEAR(gained_rate, 0.005, 4 * gained_sigma);
  // Wrong labels use the scene's property classes (heat, water), never radiation.
  EXPECT_EQ(gained_by_class[3], 0u);
  EXPECT_GT(gained_by_class[1], 0u);
  EXPECT_GT(gained_by_class[2], 0u);
}

TEST(SimLabels, TemperatureHotInHeatRegionsOnly) {
  SimulatorConfig c = quietConfig();
  c.temperature.enabled = true;
  const Simulator sim(c, roomScene(), ClassTable::defaults());
  std::vector<ClassId> truth;
  const LabeledCloud scan = sim.scan(0, &truth);
  ASSERT_TRUE(scan.hasProperty());
  std::vector<double> hot, cold;
  for (std::size_t i = 0; i < scan.size(); ++i) (truth[i] == 1 ? hot : cold).push_back(scan.property[i]);
  ASSERT_GT(hot.size(), 100u);
  EXPECT_NEAR(stats(hot).mean, c.temperature.hot_c, 0.5);
  EXPECT_NEAR(stats(cold).mean, c.temperature.ambient_c, 0.1);
  EXPECT_NEAR(stats(cold).std, c.temperature.noise_sigma_c, 0.1);
  // The temperature stream is separate: switching it on changes no point or class.
  SimulatorConfig off = c;
  off.temperature.enabled = false;
  const LabeledCloud plain = Simulator(off, roomScene(), ClassTable::defaults()).scan(0);
  EXPECT_EQ(plain.points, scan.points);
  EXPECT_EQ(plain.classes, scan.classes);
}

// ---- odometry --------------------------------------------------------------------------------

TEST(SimOdometry, DefaultsAreTheSpecification) {
  const OdometryNoiseConfig c;
  EXPECT_DOUBLE_EQ(c.forward_scale_sigma, 0.05);
  EXPECT_DOUBLE_EQ(c.lateral_sigma, 0.03);
  EXPECT_DOUBLE_EQ(c.yaw_sigma_deg, 0.25);
  EXPECT_DOUBLE_EQ(c.skid_fraction, 0.05);
  EXPECT_DOUBLE_EQ(c.slip_probability, 0.08);
  EXPECT_DOUBLE_EQ(c.slip_min, 0.2);
  EXPECT_DOUBLE_EQ(c.slip_max, 0.5);
  const RobotConfig r;
  EXPECT_DOUBLE_EQ(r.max_speed, 0.1);
  EXPECT_DOUBLE_EQ(r.frame_distance, 1.0);
  EXPECT_DOUBLE_EQ(r.frame_turn_deg, 15.0);
}

TEST(SimOdometry, ErrorStatisticsMatchConfiguredDistributions) {
  const OdometryNoiseConfig c;
  const int n = 20000;
  // Straight frames of 1 m.
  std::vector<double> scale, lateral, yaw_straight;
  std::size_t slips = 0;
  for (int i = 0; i < n; ++i) {
    Rng rng(7, RngStream::Odometry, i);
    bool slipped = false;
    const PlanarIncrement m = noisyIncrement({1.0, 0.0, 0.0}, c, rng, &slipped);
    slips += slipped;
    if (!slipped) scale.push_back(m.forward - 1.0);
    lateral.push_back(m.lateral);
    yaw_straight.push_back(m.yaw / kDeg);
  }
  EXPECT_NEAR(stats(scale).mean, 0.0, 4 * 0.05 / std::sqrt(n));
  EXPECT_NEAR(stats(scale).std, 0.05, 0.002);
  EXPECT_NEAR(stats(lateral).mean, 0.0, 4 * 0.03 / std::sqrt(n));
  EXPECT_NEAR(stats(lateral).std, 0.03, 0.001);
  EXPECT_NEAR(stats(yaw_straight).std, 0.25, 0.01);
  EXPECT_NEAR(static_cast<double>(slips) / n, 0.08, 4 * std::sqrt(0.08 * 0.92 / n));
  // Turns on the spot (15°, no forward motion): yaw error σ² = 0.25² + (5 % of 15°)²; every
  // forward report is a slip of U(0.2, 0.5) m.
  std::vector<double> yaw_turn, slip_extra;
  for (int i = 0; i < n; ++i) {
    Rng rng(8, RngStream::Odometry, i);
    const PlanarIncrement m = noisyIncrement({0.0, 0.0, 15.0 * kDeg}, c, rng);
    yaw_turn.push_back(m.yaw / kDeg - 15.0);
    if (m.forward != 0.0) slip_extra.push_back(m.forward);
  }
  EXPECT_NEAR(stats(yaw_turn).mean, 0.0, 0.02);
  EXPECT_NEAR(stats(yaw_turn).std, std::hypot(0.25, 0.05 * 15.0), 0.02);
  ASSERT_GT(slip_extra.size(), 1000u);
  EXPECT_GE(*std::min_element(slip_extra.begin(), slip_extra.end()), 0.2);
  EXPECT_LE(*std::max_element(slip_extra.begin(), slip_extra.end()), 0.5);
  EXPECT_NEAR(stats(slip_extra).mean, 0.35, 0.01);
  EXPECT_NEAR(stats(slip_extra).std, 0.3 / std::sqrt(12.0), 0.005);
}

TEST(SimOdometry, AccumulatedOdometryIsPlanarAndStartsAtTruth) {
  PoseList truth;
  for (int i = 0; i < 50; ++i) {
    Eigen::Isometry3d T = fromXyYaw(0.9 * i, 0.1 * i, 0.05 * i);
    T.translation().z() = 0.5;
    truth.push_back(T);
  }
  std::vector<bool> slips;
  const PoseList odo = accumulateOdometry(truth, OdometryNoiseConfig{}, 3, &slips);
  ASSERT_EQ(odo.size(), truth.size());
  EXPECT_TRUE(odo[0].isApprox(truth[0]));
  for (const auto& T : odo) {
    EXPECT_NEAR(T.translation().z(), 0.5, 1e-12);
    EXPECT_NEAR(T.linear()(2, 2), 1.0, 1e-12);  // no roll or pitch
  }
  EXPECT_GT((odo.back().translation() - truth.back().translation()).norm(), 1e-3);
  // No noise at all → odometry equals truth.
  OdometryNoiseConfig none;
  none.forward_scale_sigma = none.lateral_sigma = none.yaw_sigma_deg = none.skid_fraction = 0.0;
  none.slip_probability = 0.0;
  const PoseList exact = accumulateOdometry(truth, none, 3);
  for (std::size_t i = 0; i < truth.size(); ++i) EXPECT_TRUE(exact[i].isApprox(truth[i], 1e-9));
}

// ---- route and scenes ------------------------------------------------------------------------

TEST(SimRoute, FramesEveryMetreOrFifteenDegrees) {
  const Scene naraha = builtinScene("naraha");
  const RobotConfig robot;
  const auto samples = sampleRoute(naraha.route, robot);
  ASSERT_GT(samples.size(), 2u);
  for (std::size_t i = 1; i < samples.size(); ++i) {
    const double d = samples[i].travelled - samples[i - 1].travelled;
    const double a = samples[i].turned - samples[i - 1].turned;
    EXPECT_LE(d, 1.0 + 1e-9);
    EXPECT_LE(a, 15.0 * kDeg + 1e-9);
    EXPECT_LE(std::hypot(samples[i].x - samples[i - 1].x, samples[i].y - samples[i - 1].y), 1.0 + 1e-9);
    // Every frame but the last is triggered by one of the two thresholds.
    if (i + 1 < samples.size()) EXPECT_TRUE(std::abs(d - 1.0) < 1e-6 || std::abs(a - 15.0 * kDeg) < 1e-6);
    EXPECT_NEAR(samples[i].time - samples[i - 1].time, d / robot.max_speed, 1e-6);
  }
  // Turning on the spot (corridor's U-turn) triggers every 15°.
  const auto corridor = sampleRoute(builtinScene("corridor").route, robot);
  std::size_t spins = 0;
  for (std::size_t i = 1; i < corridor.size(); ++i)
    if (corridor[i].travelled == corridor[i - 1].travelled) ++spins;
  EXPECT_EQ(spins, 12u);  // 180° / 15°
}

TEST(SimRoute, NarahaLoopIsClosedAbout120mAndThenRepeated) {
  const Scene s = builtinScene("naraha");
  ASSERT_GT(s.route.loop_waypoints, 2u);
  EXPECT_EQ(s.route.waypoints.front(), s.route.waypoints[s.route.loop_waypoints - 1]);
  const auto samples = sampleRoute(s.route, RobotConfig{});
  // The robot returns to its start pose after ~120 m, then drives on (repeating the corridor).
  std::size_t back = 0;
  for (std::size_t i = 1; i < samples.size(); ++i)
    if (samples[i].travelled > 50.0 && std::hypot(samples[i].x - samples[0].x, samples[i].y - samples[0].y) < 0.05 &&
        std::abs(std::remainder(samples[i].yaw - samples[0].yaw, 2 * M_PI)) < 1e-6) {
      back = i;
      break;
    }
  ASSERT_GT(back, 0u) << "the route never returns to its start pose";
  EXPECT_GT(samples[back].travelled, 110.0);
  EXPECT_LT(samples[back].travelled, 130.0);
  EXPECT_GT(samples.back().travelled - samples[back].travelled, 10.0);
  EXPECT_GT(samples.size(), 130u);
  EXPECT_LT(samples.size(), 200u);
}

// closed_route: every built-in scene's loop, driven round and round, steps from its last scan to
// its first as from any scan to the next (no jump), and the loop is the whole of it.
TEST(SimRoute, AClosedRouteGoesRoundWithoutAJumpInEveryBuiltinScene) {
  RobotConfig robot;
  robot.frame_distance = 0.5;
  for (const auto& name : builtinSceneNames()) {
    const Scene s = builtinScene(name);
    const auto samples = sampleRoute(closedLoop(s.route, name), robot, true);
    ASSERT_GT(samples.size(), 20u) << name;
    const RouteSample &first = samples.front(), &last = samples.back();
    const double step = std::hypot(first.x - last.x, first.y - last.y);
    const double turn = std::abs(std::remainder(first.yaw - last.yaw, 2 * M_PI));
    EXPECT_LE(step, robot.frame_distance + 1e-9) << name;
    EXPECT_LE(turn, robot.frame_turn_deg * kDeg + 1e-9) << name;
    EXPECT_GT(step + turn, 1e-6) << name << ": the last scan repeats the first";
    // The open route drives on past its loop (naraha, tanks) or back (corridor): the closed one
    // ends at the loop's end, where the open one is back at its start.
    const auto open = sampleRoute(s.route, robot);
    EXPECT_LE(last.travelled, open.back().travelled + 1e-9) << name;
  }
  // The corridor's way back ends facing the wrong way: the closed route turns round on the spot.
  const auto corridor = sampleRoute(closedLoop(builtinScene("corridor").route, "corridor"), RobotConfig{}, true);
  std::size_t spins = 0;
  for (std::size_t i = 1; i < corridor.size(); ++i) spins += corridor[i].travelled == corridor[i - 1].travelled;
  EXPECT_EQ(spins, 12u + 11u);  // the U-turn (12 × 15°) and the turn back, whose last step is the first scan
}

TEST(SimRoute, AClosedRouteNeedsALoop) {
  Route open;
  open.waypoints = {{0, 0}, {10, 0}, {10, 10}};
  EXPECT_NE(errorOf([&] { closedLoop(open, "scene x"); }).find("scene x: the route has no closed loop"), std::string::npos);
  open.loop_waypoints = 3;
  EXPECT_NE(errorOf([&] { closedLoop(open, "scene x"); }).find("does not end at its first waypoint"), std::string::npos);
  EXPECT_NE(errorOf([&] { sampleRoute(open, RobotConfig{}, true); }).find("a closed route must end at its first waypoint"),
            std::string::npos);
}

TEST(SimScene, RouteHasClearanceInEveryBuiltinScene) {
  for (const auto& name : builtinSceneNames()) {
    const Scene s = builtinScene(name);
    const RayCaster caster(s.mesh);
    for (const auto& p : sampleRoute(s.route, RobotConfig{})) {
      // The crawler (1 m x 0.4 m) needs ~0.55 m around its centre, at track height.
      for (int k = 0; k < 72; ++k) {
        const Eigen::Vector3f d(std::cos(5.0 * k * kDeg), std::sin(5.0 * k * kDeg), 0.0f);
        const RayHit h = caster.cast(Eigen::Vector3f(p.x, p.y, 0.15f), d);
        ASSERT_TRUE(!h.hit() || h.distance > 0.55f)
            << name << ": obstacle " << h.distance << " m from the route at " << p.x << ", " << p.y;
      }
    }
  }
}

TEST(SimScene, NarahaMatchesTheIssue) {
  const Scene s = builtinScene("naraha");
  const RayCaster caster(s.mesh);
  auto down = [&](double x, double y) {
    return 10.0f - caster.cast(Eigen::Vector3f(x, y, 10.0f), -Eigen::Vector3f::UnitZ()).distance;
  };
  // Six identical tanks (3 m high) 4 m apart with 2 m gaps; 5 m walls; 0.6 m pillars.
  for (int k = 0; k < 6; ++k) {
    EXPECT_NEAR(down(11.0 + 4 * k, 19.0), 3.0, 1e-4);
    EXPECT_NEAR(down(11.0 + 4 * k + 0.95, 19.0), 3.0, 1e-4);
    EXPECT_NEAR(down(11.0 + 4 * k + 2.0, 19.0), 0.0, 1e-4);
  }
  EXPECT_NEAR(down(-0.1, 12.0), 5.0, 1e-4);
  EXPECT_NEAR(down(16.0, 8.0), 5.0, 1e-4);
  EXPECT_NEAR(down(16.4, 8.0), 0.0, 1e-4);
  // Two identical staircases: same height profile at the same offsets.
  for (double dx : {0.2, 0.6, 1.0, 2.2, 3.0}) EXPECT_NEAR(down(10.5 + dx, 7.5), down(26.5 + dx, 7.5), 1e-5);
  // The corridor is 3 m wide and 20 m long.
  const RayHit north = caster.cast(Eigen::Vector3f(20, 2.5, 2.0), Eigen::Vector3f::UnitY());
  const RayHit south = caster.cast(Eigen::Vector3f(20, 2.5, 2.0), -Eigen::Vector3f::UnitY());
  EXPECT_NEAR(north.distance + south.distance, 3.0, 1e-4);
  EXPECT_GT(down(10.1, 2.5), 3.0);
  EXPECT_NEAR(down(9.9, 2.5), 0.0, 1e-4);
  EXPECT_GT(down(29.9, 2.5), 3.0);
  EXPECT_NEAR(down(30.1, 2.5), 0.0, 1e-4);

  // Three heat sources and three irregular 1–3 m puddles; one of each near the corridor and
  // near the tanks.
  int heat = 0, water = 0;
  bool heat_corridor = false, water_corridor = false, heat_tanks = false, water_tanks = false;
  for (const auto& r : s.regions) {
    const Eigen::Vector3d lo = r.boundsMin(), hi = r.boundsMax(), c = 0.5 * (lo + hi);
    const bool near_corridor = c.x() > 9 && c.x() < 31 && c.y() > 0 && c.y() < 5.5;
    bool near_tank = false;
    for (int k = 0; k < 6; ++k) near_tank = near_tank || std::hypot(c.x() - 11 - 4 * k, c.y() - 19) < 3.5;
    if (r.class_id == 1) {
      ++heat;
      heat_corridor |= near_corridor;
      heat_tanks |= near_tank;
    } else if (r.class_id == 2) {
      ++water;
      water_corridor |= near_corridor;
      water_tanks |= near_tank;
      ASSERT_EQ(r.shape, PropertyRegion::Shape::Polygon);
      EXPECT_GE(r.polygon.size(), 5u);  // irregular, not a rectangle
      const double extent = (hi - lo).head<2>().maxCoeff();
      EXPECT_GE(extent, 1.0);
      EXPECT_LE(extent, 3.0);
    }
  }
  EXPECT_EQ(heat, 3);
  EXPECT_EQ(water, 3);
  EXPECT_TRUE(heat_corridor && water_corridor && heat_tanks && water_tanks);
  // scene.ply colouring: some faces carry heat and water.
  const auto& tc = s.mesh.triangle_classes;
  ASSERT_EQ(tc.size(), s.mesh.triangles.size());
  EXPECT_GT(std::count(tc.begin(), tc.end(), 1), 10);
  EXPECT_GT(std::count(tc.begin(), tc.end(), 2), 10);
}

TEST(SimScene, UnknownScenarioFails) {
  try {
    builtinScene("chernobyl");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown scenario 'chernobyl'"), std::string::npos);
  }
}

TEST(SimScene, RegionsYaml) {
  Scene s;
  parseRegionsYaml(R"(
regions:
  - {name: heater, class: heat, box: {min: [0, 0, 0], max: [1, 1, 1]}}
  - {name: puddle, class: 2, polygon: [[0, 0], [2, 0], [1, 2]], z: [-0.1, 0.1]}
route: {waypoints: [[0, 0], [5, 0]], corner_radius: 1.5}
)", "test.yaml", ClassTable::defaults(), s);
  ASSERT_EQ(s.regions.size(), 2u);
  EXPECT_EQ(s.classAt({0.5, 0.5, 0.5}), 1);
  EXPECT_EQ(s.classAt({1.0, 0.5, 0.0}), 1);  // first region wins
  EXPECT_EQ(s.classAt({1.0, 1.5, 0.0}), 2);
  EXPECT_EQ(s.classAt({0.1, 1.5, 0.0}), 0);  // outside the triangle
  EXPECT_EQ(s.classAt({1.0, 1.5, 0.2}), 0);  // above the prism
  EXPECT_DOUBLE_EQ(s.route.corner_radius, 1.5);
  auto error = [](const std::string& yaml) {
    Scene t;
    try {
      parseRegionsYaml(yaml, "bad.yaml", ClassTable::defaults(), t);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error("regions: [{name: r, class: lava, box: {min: [0,0,0], max: [1,1,1]}}]").find("bad.yaml: region 'r' has unknown class 'lava'"), std::string::npos);
  EXPECT_NE(error("regions: [{name: r, class: 9, box: {min: [0,0,0], max: [1,1,1]}}]").find("unknown class '9'"), std::string::npos);
  EXPECT_NE(error("regions: [{name: r, class: heat, box: {min: [0,0,0], max: [-1,1,1]}}]").find("min > max"), std::string::npos);
  EXPECT_NE(error("regions: [{name: r, class: heat}]").find("needs a 'box' or a 'polygon'"), std::string::npos);
  EXPECT_NE(error("regions: [{name: r, class: heat, sphere: 1}]").find("unknown key 'sphere'"), std::string::npos);
  EXPECT_NE(error("route: {waypoints: [[0, 0]]}").find("at least 2"), std::string::npos);
  EXPECT_NE(error("regions: [").find("invalid YAML"), std::string::npos);
}

// ---- determinism -----------------------------------------------------------------------------

TEST(SimDeterminism, SameSeedSameScansAnyOrderDifferentSeedDiffers) {
  SimulatorConfig c;
  c.max_frames = 6;
  const Simulator a(c, builtinScene("naraha"), ClassTable::defaults());
  const Simulator b(c, builtinScene("naraha"), ClassTable::defaults());
  std::vector<LabeledCloud> parallel(a.frames());
  tbb::parallel_for(std::size_t{0}, a.frames(), [&](std::size_t i) { parallel[a.frames() - 1 - i] = a.scan(a.frames() - 1 - i); });
  for (std::size_t i = 0; i < a.frames(); ++i) {
    const LabeledCloud s = b.scan(i);
    EXPECT_EQ(s.points, parallel[i].points);
    EXPECT_EQ(s.classes, parallel[i].classes);
    EXPECT_EQ(s.intensity, parallel[i].intensity);
  }
  for (std::size_t i = 0; i < a.frames(); ++i) EXPECT_TRUE(a.odometry()[i].isApprox(b.odometry()[i], 0.0));
  SimulatorConfig other = c;
  other.seed = 2;
  const Simulator d(other, builtinScene("naraha"), ClassTable::defaults());
  EXPECT_NE(d.scan(0).points, b.scan(0).points);
  EXPECT_FALSE(d.odometry().back().isApprox(b.odometry().back(), 1e-9));
  // Asking for fewer frames does not change the ones produced.
  SimulatorConfig fewer = c;
  fewer.max_frames = 3;
  const Simulator e(fewer, builtinScene("naraha"), ClassTable::defaults());
  EXPECT_EQ(e.frames(), 3u);
  EXPECT_EQ(e.scan(2).points, b.scan(2).points);
  EXPECT_TRUE(e.odometry()[2].isApprox(b.odometry()[2], 0.0));
}

// ---- config ----------------------------------------------------------------------------------

TEST(SimConfig, YamlRoundTripAndOverrides) {
  SimulatorConfig c = SimulatorConfig::fromYamlString(R"(
scenario: corridor
seed: 42
sensor: {range_noise_sigma: 0.05, columns: 900}
odometry: {slip_probability: 0.0}
temperature: {enabled: true, hot_c: 80}
)", "cfg.yaml");
  EXPECT_EQ(c.scenario, "corridor");
  EXPECT_EQ(c.seed, 42u);
  EXPECT_DOUBLE_EQ(c.sensor.range_noise_sigma, 0.05);
  EXPECT_EQ(c.sensor.columns, 900);
  EXPECT_DOUBLE_EQ(c.sensor.dropout_probability, 0.01);  // untouched default
  EXPECT_DOUBLE_EQ(c.odometry.slip_probability, 0.0);
  EXPECT_TRUE(c.temperature.enabled);
  EXPECT_DOUBLE_EQ(c.temperature.hot_c, 80.0);
  const SimulatorConfig back = SimulatorConfig::fromYamlString(c.toYamlString(), "round trip");
  EXPECT_EQ(back.toYamlString(), c.toYamlString());
  EXPECT_EQ(back.sensor.columns, 900);
  EXPECT_EQ(back.seed, 42u);
}

TEST(SimConfig, BadValuesFailWithOneLineNamingTheParameter) {
  auto error = [](const std::string& yaml) {
    try {
      SimulatorConfig::fromYamlString(yaml, "cfg.yaml").validate("cfg.yaml");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error("sensor: {range_noise_sigma: -0.1}").find("cfg.yaml: sensor.range_noise_sigma: must be >= 0, got -0.1"), std::string::npos);
  EXPECT_NE(error("odometry: {lateral_sigma: -1}").find("odometry.lateral_sigma: must be >= 0"), std::string::npos);
  EXPECT_NE(error("odometry: {slip_probability: 1.5}").find("odometry.slip_probability: must be in [0, 1], got 1.5"), std::string::npos);
  EXPECT_NE(error("labels: {false_property: -0.01}").find("labels.false_property"), std::string::npos);
  EXPECT_NE(error("scenario: moon").find("unknown scenario 'moon'"), std::string::npos);
  EXPECT_NE(error("sensor: {min_range: 5, max_range: 2}").find("sensor.min_range: must be < sensor.max_range"), std::string::npos);
  EXPECT_NE(error("sensor: {channels: 0}").find("sensor.channels"), std::string::npos);
  EXPECT_NE(error("sensor: {rang_noise: 0.1}").find("cfg.yaml: sensor: unknown key 'rang_noise'"), std::string::npos);
  EXPECT_NE(error("speed: 3").find("unknown key 'speed'"), std::string::npos);
  EXPECT_NE(error("sensor: {columns: many}").find("sensor.columns: must be a whole number, got 'many'"), std::string::npos);
  EXPECT_NE(error("scene: room.ply").find("needs a regions file"), std::string::npos);
  EXPECT_EQ(error("sensor: {range_noise_sigma: 0}"), "no error");
  for (const std::string& e : {error("odometry: {yaw_sigma_deg: -2}"), error("scenario: x")})
    EXPECT_EQ(e.find('\n'), std::string::npos);
}

TEST(SimConfig, EmptySceneAndUnknownRegionClassFail) {
  Scene empty;
  empty.route.waypoints = {{0, 0}, {1, 0}};
  EXPECT_THROW(Simulator(SimulatorConfig{}, empty, ClassTable::defaults()), Error);
  Scene room = roomScene();
  room.regions.push_back(PropertyRegion::box("alien", 42, {0, 0, 0}, {1, 1, 1}));
  try {
    Simulator sim(SimulatorConfig{}, room, ClassTable::defaults());
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("region 'alien' has unknown class 42"), std::string::npos);
  }
}

TEST(SimConfig, ShippedFilesMatchTheCode) {
  // config/scenarios/simulator_defaults.yaml documents every key with the default of the code.
  const SimulatorConfig file = SimulatorConfig::fromYamlFile(
      test::sourceDir("config/scenarios/simulator_defaults.yaml"));
  EXPECT_EQ(file.toYamlString(), SimulatorConfig{}.toYamlString());
  // config/scenarios/room_regions.yaml parses, with its two regions and a closed route.
  Scene room = roomScene();
  room.regions.clear();
  parseRegionsYaml(readTextFile(test::sourceDir("config/scenarios/room_regions.yaml")),
                   "room_regions.yaml", ClassTable::defaults(), room);
  ASSERT_EQ(room.regions.size(), 2u);
  EXPECT_EQ(room.route.waypoints.front(), room.route.waypoints.back());
  EXPECT_EQ(room.route.loop_waypoints, 5u);
  EXPECT_EQ(room.classAt({8.0, 0.0, 1.0}), 1);
  EXPECT_EQ(room.classAt({-2.0, -0.5, 0.0}), 2);
}
