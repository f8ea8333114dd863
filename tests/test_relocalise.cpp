// Tracking that survives large, unpredicted motion (issue 19): the simulated crawler's worst day
// (preset, kicks unseen by the encoders, lost scans, no odometry.txt), the odometry's frame
// status and recovery (relocalised / fallback with reasons), and real data with large motion.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/sim/simulator.hpp"
#include "hazmap/io/trajectory.hpp"
#include "odometry/frame_judgement.hpp"
#include "odometry/odometry_checks.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

constexpr double kDeg = M_PI / 180.0;
namespace fs = std::filesystem;

TEST(WorstDay, PresetIsReadBeforeTheOtherKeysAndTheDefaultsStayOff) {
  const sim::SimulatorConfig defaults;
  EXPECT_EQ(defaults.preset, "none");
  EXPECT_EQ(defaults.upsets.yaw_kick_probability, 0.0);
  EXPECT_EQ(defaults.upsets.drop_probability, 0.0);
  EXPECT_TRUE(OdometryConfig::defaults().recovery.relocalise);  // on: recovery is never worse than the guess
  EXPECT_EQ(defaults.odometry.slip_max, 0.5);
  EXPECT_TRUE(defaults.wheel_odometry);
  // The preset comes last in the file, yet the explicit key next to it wins.
  const auto c = sim::SimulatorConfig::fromYamlString("odometry: {slip_max: 1.5}\npreset: worst-day\n", "t.yaml");
  EXPECT_EQ(c.preset, "worst-day");
  EXPECT_EQ(c.odometry.slip_max, 1.5);
  EXPECT_EQ(c.odometry.slip_probability, 0.1);
  EXPECT_EQ(c.upsets.yaw_kick_max_deg, 45.0);
  EXPECT_GT(c.upsets.yaw_kick_probability, 0.0);
  // The written config reads back to the same values.
  const auto again = sim::SimulatorConfig::fromYamlString(c.toYamlString(), "again.yaml");
  EXPECT_EQ(again.toYamlString(), c.toYamlString());
  EXPECT_THROW(sim::SimulatorConfig::fromYamlString("preset: bad-day\n", "t.yaml"), Error);
  EXPECT_THROW(sim::SimulatorConfig::fromYamlString("upsets: {yaw_kick_min_deg: 50}\n", "t.yaml").validate(), Error);
}

TEST(WorstDay, KicksAreTrueMotionTheEncodersMissAndScansAreLost) {
  sim::SimulatorConfig plain;
  plain.max_frames = 80;
  const sim::Simulator calm(plain);
  EXPECT_TRUE(calm.yawKicks().empty());
  const sim::Simulator bad(sim::SimulatorConfig::withPreset("worst-day", plain, "test"));
  ASSERT_EQ(bad.frames(), 80u);
  ASSERT_EQ(bad.yawKicks().size(), 80u);
  // Lost scans: the worst day covers more of the route in as many frames.
  EXPECT_GT(bad.routeLength(), calm.routeLength() + 3.0);
  std::size_t kicks = 0;
  double biggest_step = 0.0;
  for (std::size_t i = 1; i < bad.frames(); ++i) {
    const Eigen::Isometry3d truth = bad.groundTruth()[i - 1].inverse() * bad.groundTruth()[i];
    const Eigen::Isometry3d odo = bad.odometry()[i - 1].inverse() * bad.odometry()[i];
    biggest_step = std::max(biggest_step, translationNorm(truth));
    const double kick = bad.yawKicks()[i];
    if (kick == 0.0) continue;
    ++kicks;
    EXPECT_GE(std::abs(kick), 10 * kDeg - 1e-9);
    EXPECT_LE(std::abs(kick), 45 * kDeg + 1e-9);
    // The encoders miss the kick: their yaw differs from the true one by about the kick.
    EXPECT_NEAR(yawOf(truth.inverse() * odo), -kick, 3 * kDeg) << "frame " << i;
  }
  EXPECT_GE(kicks, 3u);
  EXPECT_GT(biggest_step, 1.5);  // a lost scan doubles an increment
}

TEST(WorstDay, NoOdometryFileWithoutWheelOdometry) {
  const auto dir = test::scratchDir() / "seq";
  const auto r = test::runCli("simulate --scenario corridor --worst-day --no-odometry --frames 4 --out " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(std::filesystem::exists(dir / "poses.txt"));
  EXPECT_FALSE(std::filesystem::exists(dir / "odometry.txt"));
  EXPECT_NE(readTextFile(dir / "simulation.yaml").find("preset: worst-day"), std::string::npos);
}

/// Per-frame increment errors of an odometry run against the truth, scored on the frames as they
/// ended (a lost frame's pose is re-estimated once a later frame is verified).
struct Score {
  std::size_t frames = 0, within = 0, silently_wrong = 0, relocalised = 0, flagged = 0;
  double mean_position_error = 0.0;  ///< m, no alignment: a proxy for the map error
  double within_share() const { return frames ? double(within) / double(frames) : 0.0; }
};

enum class Guess { None, Wheel, Exact };

Score trackWorstDay(const sim::Simulator& sim, bool wheel, OdometryConfig config, Guess guess = Guess::None) {
  if (guess == Guess::None && wheel) guess = Guess::Wheel;
  config.recovery.relocalise = true;
  config.recovery.relocalise_suspect = true;
  Odometry odo(sim.classTable(), config);
  for (std::size_t i = 0; i < sim.frames(); ++i) {
    std::optional<Eigen::Isometry3d> inc;
    if (guess == Guess::Wheel && i > 0) inc = sim.odometry()[i - 1].inverse() * sim.odometry()[i];
    if (guess == Guess::Exact && i > 0) inc = sim.groundTruth()[i - 1].inverse() * sim.groundTruth()[i];
    odo.addFrame(sim.scan(i), inc);
  }
  Score s;
  for (std::size_t i = 0; i < sim.frames(); ++i) {
    const OdometryFrame& f = odo.frames()[i];
    s.mean_position_error += (f.pose.translation() - sim.groundTruth()[i].translation()).norm() / double(sim.frames());
    if (i == 0) continue;
    const Eigen::Isometry3d truth = sim.groundTruth()[i - 1].inverse() * sim.groundTruth()[i];
    const Eigen::Isometry3d error = truth.inverse() * f.increment;
    const double t = translationNorm(error), r = rotationAngle(error);
    ++s.frames;
    s.within += t <= 0.05 && r <= 0.5 * kDeg;
    s.relocalised += f.status == FrameStatus::Relocalised;
    s.flagged += isFlagged(f.status);
    if ((t > 0.2 || r > 2 * kDeg) && !isFlagged(f.status)) ++s.silently_wrong;
  }
  std::printf("worst day, %s: %zu/%zu frames within 5 cm / 0.5 deg, %zu relocalised, %zu flagged, "
              "%zu silently wrong, mean position error %.3f m\n",
              guess == Guess::Exact ? "exact odometry" : wheel ? "with wheel odometry" : "without wheel odometry",
              s.within, s.frames, s.relocalised, s.flagged, s.silently_wrong, s.mean_position_error);
  return s;
}

sim::Simulator worstDay(const std::string& scenario, std::size_t frames) {
  sim::SimulatorConfig c;
  c.scenario = scenario;
  c.max_frames = frames;
  return sim::Simulator(sim::SimulatorConfig::withPreset("worst-day", c, "test"));
}

// The corridor without odometry: along the corridor the walls cannot tell the motion (the open
// ends constrain it weakly), and from frame 1 ICP locks onto "no motion". What is achievable is
// honesty: with relocalise_suspect such frames are flagged (weak axis). With lost frames kept out
// of the map and re-estimated (reestimate_lost_frames) the corridor's weak-axis ratios sat just
// above kSuspectWeakAxisRatio (0.15) for some frames, which stayed `tracked` 1 m wrong (4 of
// 29); flagging at kFlagWeakAxisRatio (0.25) and probing every recovery answer along its
// weakest axis leaves 1 (a lost frame re-estimated 1 m along the corridor: docs/registration.md);
// with re-estimated lost frames probed and placed by their labels too, none.
// The issue's targets, which the corridor does not meet, are measured by
// scripts/corridor_observability.sh (TARGETS=1).
TEST(WorstDay, CorridorWithoutOdometryIsFlaggedNotSilentlyWrong) {
  const Score s = trackWorstDay(worstDay("corridor", 30), /*wheel=*/false, OdometryConfig::defaults());
  EXPECT_EQ(s.silently_wrong, 0u);
  EXPECT_GE(s.flagged, 20u);  // most frames: the motion along the corridor is unknown
}

namespace {

struct GyroWorstDay {
  std::size_t far = 0, silent = 0;  ///< frames off by > 20 cm / 2°; of those tracked or relocalised
  std::size_t by_scan = 0;          ///< frames flagged by the scan's own surfaces
  std::size_t from_wheels = 0;      ///< ... of those, because ICP left the wheels along the axis
};

// `hazmap odometry` on the corridor worst day with the simulated gyro (scripts/imu_worst_day.sh's
// protocol), scored as its table.
GyroWorstDay gyroWorstDay(int seed, bool wheels) {
  const fs::path dir = test::scratchDir() / "worst_day_gyro";
  fs::remove_all(dir);
  GyroWorstDay out;
  const auto sim = test::runCli("simulate --scenario corridor --worst-day --seed " + std::to_string(seed) +
                                " --frames 100 --imu-rate 200 --out " + (dir / "seq").string());
  EXPECT_EQ(sim.exit_code, 0) << sim.output;
  const auto run = test::runCli("odometry " + (dir / "seq").string() + " --out " + (dir / "run").string() + " --quiet" +
                                (wheels ? "" : " --no-wheel") +
                                " --set recovery.relocalise=true --set recovery.relocalise_suspect=true");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  if (sim.exit_code != 0 || run.exit_code != 0) return out;
  const Trajectory truth = readKittiTrajectory(dir / "seq" / "poses.txt");
  const Trajectory est = readKittiTrajectory(dir / "run" / "poses.txt");
  std::ifstream frames(dir / "run" / "frames.csv");
  std::vector<std::string> status;
  for (std::string line; std::getline(frames, line);) {
    const std::size_t a = line.find(','), b = line.find(',', a + 1), c = line.find(',', b + 1);
    status.push_back(line.substr(b + 1, c - b - 1));
    out.by_scan += line.find("in the scan's own surfaces") != std::string::npos;
    out.from_wheels += line.find("from the wheels along it") != std::string::npos;
  }
  EXPECT_EQ(est.poses.size(), truth.poses.size());
  EXPECT_EQ(status.size(), est.poses.size() + 1);  // the header
  if (est.poses.size() != truth.poses.size() || status.size() != est.poses.size() + 1) return out;
  for (std::size_t i = 1; i < est.poses.size(); ++i) {
    const Eigen::Isometry3d error = (truth.poses[i - 1].inverse() * truth.poses[i]).inverse() *
                                    (est.poses[i - 1].inverse() * est.poses[i]);
    if (translationNorm(error) <= 0.2 && rotationAngle(error) <= 2 * kDeg) continue;
    ++out.far;
    out.silent += status[i + 1] == "tracked" || status[i + 1] == "relocalised";
  }
  std::printf("corridor worst day seed %d, gyro, %s: %zu of %zu far-off frames silently wrong, %zu flagged by the "
              "scan's own surfaces (%zu leaving the wheels)\n",
              seed, wheels ? "wheels" : "no wheels", out.silent, out.far, out.by_scan, out.from_wheels);
  return out;
}

}  // namespace

// The corridor worst day without wheels, with the gyro (issue 36): the rotation is now right, so
// frames are no longer lost to it, and from frame 83 on (seed 1) ICP stood still `tracked` while
// the robot drove 1 m a frame: the local map, smeared by the frames before, gave its Hessian an
// axis along the corridor that the walls do not have (20 of 66 far-off frames silently wrong).
// The scan's own surfaces (scanWeakHorizontalAxis, asked without wheel odometry) flag them: 0 of
// 64 (measured 2026-12-04, docs/formats.md). Bounds, not counts: the run is chaotic.
TEST(WorstDay, CorridorWithTheGyroWithoutWheelsIsFlaggedNotSilentlyWrong) {
  const GyroWorstDay s = gyroWorstDay(1, /*wheels=*/false);
  EXPECT_LE(s.silent, 3u);  // 20 before the scan's own surfaces were asked
  EXPECT_GE(s.by_scan, 1u);  // the check ran (else the bound proves nothing)
}

// The same with wheels, seed 3: frames 66 and 80 stood `tracked` 0.22-0.24 m off along the
// corridor, where ICP had left wheels that were within 4 cm (the map's features integrated where
// flagged frames put them). The scan's own surfaces now flag a frame whose answer lies more than
// kFlagWheelDisagreement from the wheels along their weak axis: 2 → 0 silently wrong (2026-12-05,
// docs/formats.md), the other wheel rows of seeds 1-3 and naraha unchanged.
TEST(WorstDay, CorridorWithTheGyroAndWheelsIsFlaggedNotSilentlyWrong) {
  const GyroWorstDay s = gyroWorstDay(3, /*wheels=*/true);
  EXPECT_LE(s.silent, 1u);  // 2 before
  EXPECT_GE(s.from_wheels, 1u);
  EXPECT_GE(s.far, 10u);  // the day is as hard as it was (24 of 99 far off)
}

// The scan's own surfaces: a corridor (two walls, floor, ceiling) says nothing along it, a room
// with end walls does; the axis comes out in the world frame of the pose.
TEST(ScanSurfaces, ACorridorIsWeakAlongItAndARoomIsNot) {
  // Walls at y = ±1.5 m, floor and ceiling at z = ±1.5 m, from x = -half to +half; end walls
  // at x = ±half when closed. Points every 0.25 m.
  const auto box = [](double half, bool closed) {
    LabeledCloud c;
    for (double x = -half; x <= half + 1e-9; x += 0.25)
      for (double u = -1.5; u <= 1.5 + 1e-9; u += 0.25)
        for (const Eigen::Vector3d& p : {Eigen::Vector3d(x, -1.5, u), Eigen::Vector3d(x, 1.5, u),
                                         Eigen::Vector3d(x, u, -1.5), Eigen::Vector3d(x, u, 1.5)})
          c.push_back(p.cast<float>());
    for (double y = -1.5; closed && y <= 1.5 + 1e-9; y += 0.25)
      for (double z = -1.5; z <= 1.5 + 1e-9; z += 0.25) {
        c.push_back(Eigen::Vector3f(-half, y, z));
        c.push_back(Eigen::Vector3f(half, y, z));
      }
    return c;
  };
  const LabeledCloud corridor = box(10.0, false), room = box(3.0, true);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(30.0, -4.0, 0.5);
  const auto axis = scanWeakHorizontalAxis(corridor, pose, kScanWeakAxisRatio);
  ASSERT_TRUE(axis.has_value());
  EXPECT_GT(std::abs(axis->dot(pose.linear() * Eigen::Vector3d::UnitX())), 0.99);
  EXPECT_FALSE(scanWeakHorizontalAxis(room, pose, kScanWeakAxisRatio).has_value());
  EXPECT_FALSE(scanWeakHorizontalAxis(LabeledCloud{}, pose, kScanWeakAxisRatio).has_value());
}

// Recovery must never make tracking worse than keeping the guess (it is on by default). Tanks
// (twelve identical tanks) was where it did: frames failed their checks, answers from other
// starts fitted no better than the wheel-odometry guess yet replaced it, and property ICP's mean
// error on seed 3 went 0.925 -> 2.287 m; every such answer must now beat the guess's own surface
// fit, and a degenerate one is not accepted. Until 2026-12-06 9 / 4 / 8 frames of seeds 2 / 3 / 5
// tried recovery (off 0.893 / 0.920 / 0.788 m, on 0.706 / 0.920 / 0.788 m). Since the floor no
// longer sets the others' robust scale (docs/registration.md, "Open fields") the tanks track to
// 4-6 cm and no frame fails: recovery must stay out of the way — on and off agree, and at most a
// frame or two (a chaotic run on another machine) may try it. Recovery itself is exercised where
// frames do fail: the worst days below (naraha: >= 3 frames relocalised, each within 5 cm).
TEST(Relocalise, NeverWorseThanTheGuessOnTanks) {
  std::size_t tried = 0;
  for (const std::uint64_t seed : {2, 3, 5}) {
    sim::SimulatorConfig sc;
    sc.scenario = "tanks";
    sc.seed = seed;
    const sim::Simulator sim(sc);
    const auto run = [&](bool relocalise) {
      OdometryConfig c = OdometryConfig::defaults();
      c.recovery.relocalise = relocalise;
      Odometry odo(sim.classTable(), c);
      double error = 0.0;
      for (std::size_t i = 0; i < sim.frames(); ++i) {
        std::optional<Eigen::Isometry3d> inc;
        if (i > 0) inc = sim.odometry()[i - 1].inverse() * sim.odometry()[i];
        const OdometryFrame& f = odo.addFrame(sim.scan(i), inc);
        error += (f.pose.translation() - sim.groundTruth()[i].translation()).norm();
        if (relocalise) tried += f.global.tried;
      }
      return error / double(sim.frames());
    };
    const double off = run(false), on = run(true);
    std::printf("tanks seed %u, property ICP: relocalise off %.3f m, on %.3f m\n", unsigned(seed), off, on);
    EXPECT_LE(on, 1.05 * off + 0.01) << "seed " << seed;
    EXPECT_LT(on, 0.15) << "seed " << seed;  // 0.047-0.062 m measured
  }
  std::printf("%zu frames tried recovery\n", tried);
  EXPECT_LE(tried, 2u);  // 0 measured
}

// The issue's targets on naraha, with and without wheel odometry: >= 98 % of the frames within
// 5 cm / 0.5 deg of their true increment, none silently wrong, and the map error (here its proxy,
// the mean position error without alignment) within 2x of the same route tracked with exact
// odometry (the kicks are true motion: a calm simulation would be another, shorter route).
TEST(WorstDay, MeetsTheIssueTargetsOnNaraha) {
  const sim::Simulator sim = worstDay("naraha", 60);
  const Score reference = trackWorstDay(sim, true, OdometryConfig::defaults(), Guess::Exact);
  for (const bool wheel : {true, false}) {
    const Score s = trackWorstDay(sim, wheel, OdometryConfig::defaults());
    EXPECT_GE(s.within_share(), 0.98) << (wheel ? "with" : "without") << " wheel odometry";
    EXPECT_EQ(s.silently_wrong, 0u) << (wheel ? "with" : "without") << " wheel odometry";
    EXPECT_LE(s.mean_position_error, 2.0 * std::max(reference.mean_position_error, 0.005))
        << (wheel ? "with" : "without") << " wheel odometry";
    EXPECT_GE(s.relocalised, 3u);  // the kicks were recovered, not just flagged
  }
}

// The labels decide where the walls cannot (the corridor): the labelled returns of frames 0-11
// of a calm corridor run, placed at their true poses, are the label map; frame 12 (beside the
// north heat panel) placed 1 m too far along the corridor is put back by its labels alone, to a
// few centimetres, and both halves of its labelled points agree.
TEST(LabelAxis, LabelsPutAFramePlacedAMetreOffBackAlongTheCorridor) {
  sim::SimulatorConfig sc;
  sc.scenario = "corridor";
  sc.max_frames = 14;
  const sim::Simulator sim(sc);
  const OdometryConfig config = OdometryConfig::defaults();
  std::vector<LabeledCloud> labels;
  std::vector<std::pair<Eigen::Isometry3d, const LabeledCloud*>> placed;
  for (std::size_t i = 0; i < 12; ++i) labels.push_back(labelledPointsOf(sim.scan(i), config, sim.classTable()));
  for (std::size_t i = 0; i < 12; ++i) placed.push_back({sim.groundTruth()[i], &labels[i]});
  const LabeledCloud map = labelMapOf(placed, sim.classTable());
  const LabeledCloud scan = labelledPointsOf(sim.scan(12), config, sim.classTable());
  Eigen::Isometry3d off = sim.groundTruth()[12];
  off.translation().x() += 1.0;
  const LabelPlacement p = placeAlongAxisByLabels({&scan, &map}, sim.classTable(), off, Eigen::Vector3d::UnitX(), config);
  std::printf("frame 12: %s\n", describe(p).c_str());
  ASSERT_TRUE(p.decided) << p.why;
  EXPECT_NEAR(p.offset, -1.0, 0.05);
  EXPECT_TRUE(p.precise);
  EXPECT_GE(p.support, 20u);
  // Lone false labels (0.5 % of the returns) are dropped: every labelled point kept lies on the
  // panel or a puddle, not scattered along the walls.
  std::size_t on_feature = 0, labelled = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (!sim.classTable().isProperty(scan.classes[i])) continue;
    ++labelled;
    const Eigen::Vector3d w = sim.groundTruth()[12] * scan.points[i].cast<double>();
    on_feature += std::abs(w.x() + 5.0 - 18.6) < 1.5 || std::abs(w.x() + 5.0 - 30.6) < 1.5;
  }
  EXPECT_GE(on_feature, labelled * 9 / 10) << on_feature << " of " << labelled;
}

// Without a labelled point in view the labels decide nothing: the frame stays flagged (the caller
// keeps ICP's answer and flags it), never placed by noise.
TEST(LabelAxis, NoLabelledPointInViewIsUndecided) {
  LabeledCloud scan, map;
  for (int i = 0; i < 200; ++i) {
    scan.push_back(Eigen::Vector3f(0.1f * i, 1.5f, 0.2f), 0);
    map.push_back(Eigen::Vector3f(0.1f * i, 1.5f, 0.2f), i > 80 && i < 95 ? 1 : 0);
  }
  const ClassTable classes = ClassTable::defaults();
  const OdometryConfig config = OdometryConfig::defaults();
  const LabelPlacement p =
      placeAlongAxisByLabels({&scan, &map}, classes, Eigen::Isometry3d::Identity(), Eigen::Vector3d::UnitX(), config);
  EXPECT_FALSE(p.decided);
  EXPECT_EQ(p.why, "no labelled point in view");
  // A repeated pattern (two identical patches 1.5 m apart, the scan seeing one) is ambiguous.
  LabeledCloud one, two;
  for (int i = 0; i < 60; ++i) {
    const float x = 0.1f * i;
    one.push_back(Eigen::Vector3f(x, 1.5f, 0.2f), i >= 20 && i < 30 ? 1 : 0);
    two.push_back(Eigen::Vector3f(x, 1.5f, 0.2f), (i >= 20 && i < 30) || (i >= 35 && i < 45) ? 1 : 0);
  }
  const LabelPlacement q =
      placeAlongAxisByLabels({&one, &two}, classes, Eigen::Isometry3d::Identity(), Eigen::Vector3d::UnitX(), config);
  EXPECT_FALSE(q.decided) << describe(q);
}

// The corridor's property row (wheel odometry, the worst day): the labels place the frames the
// walls cannot, so the route no longer drifts metres along the corridor as the encoders slip
// (docs/registration.md: seed 1, 100 frames, map error 16.3 -> 0.65 m). Measured here on 30 frames
// against the same run with label_axis.search off.
TEST(WorstDay, CorridorLabelsPlaceTheFramesTheWallsCannot) {
  const sim::Simulator sim = worstDay("corridor", 30);
  OdometryConfig off = OdometryConfig::defaults();
  off.label_axis.search = false;
  const Score without = trackWorstDay(sim, true, off);
  const Score with = trackWorstDay(sim, true, OdometryConfig::defaults());
  EXPECT_LT(with.mean_position_error, 0.5 * without.mean_position_error);
  EXPECT_GT(with.within, without.within);
  EXPECT_EQ(with.silently_wrong, 0u);
}

// A frame after a flagged one starts its increment from a pose not known along the flagged
// frame's weakest axis (issue 19): when its answer lies far from the guess along that axis, the
// previous pose's error or a slip moved it, and the increment is not known. Corridor worst day,
// seed 2, plain ICP with wheel odometry: frame 14 ("no motion" after frame 13, degenerate) was
// relocalised 1.0 m off in its increment; seed 1, property ICP, frames 35 and 45 (beside a heat
// panel, putting right frames flagged 0.4 / 0.16 m off) were tracked 0.49 / 0.26 m off
// (docs/registration.md, 2026-12-02). Fails on main (1 silently wrong).
TEST(WorstDay, AFrameAfterAFlaggedOneFarFromItsGuessIsFlagged) {
  sim::SimulatorConfig c;
  c.scenario = "corridor";
  c.seed = 2;
  c.max_frames = 15;
  const sim::Simulator sim(sim::SimulatorConfig::withPreset("worst-day", c, "test"));
  OdometryConfig plain = OdometryConfig::defaults();
  plain.registration.use_classes = false;
  const Score s = trackWorstDay(sim, /*wheel=*/true, plain);
  EXPECT_EQ(s.silently_wrong, 0u);
}

// The wheel increment into frame i of the lost-frame scenario below: the true one, but frame 8's
// turned 30 deg (nothing verifies it: the frame falls back to it) and frame 9's from wherever
// `odo` placed frame 8 (the encoders catch up: its guess is right in the world).
std::optional<Eigen::Isometry3d> lostFrameWheelIncrement(const sim::Simulator& sim, std::size_t i, const Odometry& odo) {
  const auto& truth = sim.groundTruth();
  if (i == 0) return std::nullopt;
  if (i == 8) return truth[7].inverse() * truth[8] * Eigen::AngleAxisd(30 * kDeg, Eigen::Vector3d::UnitZ());
  if (i == 9) return odo.history().pose(8).inverse() * truth[9];
  return truth[i - 1].inverse() * truth[i];
}

// A lost frame is made good once tracking recovers: frame 8 of naraha gets a wheel increment 30 deg
// off and no recovery (relocalise off), so it falls back to that guess; frame 9's encoders catch up
// (its guess is right in the world). With reestimate_lost_frames frame 8's scan waited outside the
// map, and once frame 9 is tracked it is re-registered against the map from the pose halfway
// between frames 7 and 9: both increments are right again. Without it frame 8 stays 30 deg wrong.
TEST(LostFrames, AreReestimatedOnceTrackingRecovers) {
  sim::SimulatorConfig sc;
  sc.max_frames = 12;
  const sim::Simulator sim(sc);
  const auto run = [&](bool reestimate) {
    OdometryConfig c = OdometryConfig::defaults();
    c.recovery.relocalise = false;
    c.recovery.reestimate_lost_frames = reestimate;
    Odometry odo(sim.classTable(), c);
    for (std::size_t i = 0; i < sim.frames(); ++i) {
      const OdometryFrame& f = odo.addFrame(sim.scan(i), lostFrameWheelIncrement(sim, i, odo));
      if (i == 8) EXPECT_EQ(f.status, FrameStatus::Fallback) << f.reason;
    }
    return odo.frames();
  };
  const auto increment_error = [&](const std::vector<OdometryFrame>& frames, std::size_t i) {
    return (sim.groundTruth()[i - 1].inverse() * sim.groundTruth()[i]).inverse() * frames[i].increment;
  };
  const std::vector<OdometryFrame> made_good = run(true);
  EXPECT_EQ(made_good[8].status, FrameStatus::Relocalised) << made_good[8].reason;
  EXPECT_NE(made_good[8].reason.find("re-estimated"), std::string::npos) << made_good[8].reason;
  for (std::size_t i = 8; i < made_good.size(); ++i) {
    EXPECT_LT(translationNorm(increment_error(made_good, i)), 0.05) << i;
    EXPECT_LT(rotationAngle(increment_error(made_good, i)), 0.5 * kDeg) << i;
  }
  const std::vector<OdometryFrame> left = run(false);
  EXPECT_EQ(left[8].status, FrameStatus::Fallback);
  EXPECT_GT(rotationAngle(increment_error(left, 8)), 20 * kDeg);
}

// A long mission keeps only the newest frames in full (issue 33): the same scans with a lost frame
// re-estimated (frame 8, as above) track bit for bit alike, every frame keeps its stamp, status
// and pose, and only the newest lost_frames_max + 2 records stay.
TEST(LostFrames, KeepingOnlyTheNewestFramesTracksTheSame) {
  sim::SimulatorConfig sc;
  sc.max_frames = 12;
  const sim::Simulator sim(sc);
  OdometryConfig c = OdometryConfig::defaults();
  c.recovery.relocalise = false;
  Odometry all(sim.classTable(), c), newest(sim.classTable(), c);
  newest.keepNewestFrames(0);
  for (std::size_t i = 0; i < sim.frames(); ++i) {
    const std::optional<Eigen::Isometry3d> inc = lostFrameWheelIncrement(sim, i, all);
    all.addFrame(sim.scan(i), inc);
    newest.addFrame(sim.scan(i), inc);
  }
  const std::size_t keep = static_cast<std::size_t>(c.recovery.lost_frames_max) + 2;
  ASSERT_EQ(newest.frames().size(), keep);
  EXPECT_EQ(newest.history().firstKept(), sim.frames() - keep);
  EXPECT_EQ(newest.history().size(), sim.frames());
  EXPECT_THROW(newest.history().full(0), std::out_of_range);
  EXPECT_EQ(all.frames()[8].status, FrameStatus::Relocalised);
  for (std::size_t i = 0; i < sim.frames(); ++i) {
    EXPECT_TRUE(newest.history().pose(i).matrix() == all.frames()[i].pose.matrix()) << i;
    EXPECT_EQ(newest.history().status(i), all.frames()[i].status) << i;
    EXPECT_EQ(newest.history().stamp(i), all.frames()[i].stamp) << i;
  }
  for (std::size_t i = newest.history().firstKept(); i < sim.frames(); ++i) {
    EXPECT_TRUE(newest.history().full(i).increment.matrix() == all.frames()[i].increment.matrix()) << i;
    EXPECT_EQ(newest.history().full(i).reason, all.frames()[i].reason) << i;
  }
  EXPECT_EQ(newest.trajectory().stamps, all.trajectory().stamps);
}

// A kidnapped robot: after frame 34 of naraha the robot is carried back to where it was at frame
// 6 while the encoders report an ordinary step. The first frames there fall back (a 4 m bound
// keeps the local recovery from jumping, and the local map now holds wrong scans); after
// whole_map_after of them the scan is registered against the keyframes: relocalised, right, and
// tracking goes on from there in the rebuilt local map.
struct Teleport {
  std::vector<OdometryFrame> frames;
  std::vector<Eigen::Isometry3d> truth;  ///< true pose of each fed frame
};

Teleport teleport(const sim::Simulator& sim, OdometryConfig config, std::size_t until, std::size_t to,
                  std::size_t after) {
  Odometry odo(sim.classTable(), config);
  Teleport t;
  const auto feed = [&](std::size_t i, std::optional<Eigen::Isometry3d> inc) {
    t.frames.push_back(odo.addFrame(sim.scan(i), inc));
    t.truth.push_back(sim.groundTruth()[i]);
  };
  for (std::size_t i = 0; i <= until; ++i)
    feed(i, i ? std::optional(sim.odometry()[i - 1].inverse() * sim.odometry()[i]) : std::nullopt);
  // The encoders report the step from `until` to `until + 1`; the scan is taken at `to`.
  feed(to, sim.odometry()[until].inverse() * sim.odometry()[until + 1]);
  for (std::size_t i = to + 1; i <= to + after; ++i) feed(i, sim.odometry()[i - 1].inverse() * sim.odometry()[i]);
  return t;
}

TEST(WholeMap, AKidnappedRobotIsFoundAgainAgainstTheKeyframes) {
  sim::SimulatorConfig sc;
  sc.max_frames = 40;
  const sim::Simulator sim(sc);
  OdometryConfig c = OdometryConfig::defaults();
  const Teleport t = teleport(sim, c, 34, 6, 12);
  ASSERT_GT(translationNorm(t.truth[34].inverse() * t.truth[35]), 8.0);  // a real kidnapping
  std::size_t found = 0;
  for (std::size_t k = 35; k < t.frames.size(); ++k) {
    const OdometryFrame& f = t.frames[k];
    const Eigen::Isometry3d error = t.truth[k].inverse() * f.pose;
    std::printf("frame %zu: %s, %.3f m / %.2f deg off%s\n", k, toString(f.status), translationNorm(error),
                rotationAngle(error) / kDeg, f.global.whole_map ? " (whole map)" : "");
    if (found == 0 && f.status == FrameStatus::Relocalised) {
      EXPECT_TRUE(f.global.whole_map) << f.reason;
      EXPECT_NE(f.reason.find("keyframes"), std::string::npos) << f.reason;
      found = k;
    }
    // Never a confident wrong answer: off by more than 20 cm / 2 deg only while flagged.
    if (translationNorm(error) > 0.2 || rotationAngle(error) > 2 * kDeg) EXPECT_TRUE(isFlagged(f.status)) << k;
  }
  ASSERT_GT(found, 0u) << "never re-localised";
  EXPECT_LE(found, 35u + OdometryConfig::defaults().recovery.whole_map_after);
  // From there on the robot is where it truly is, and stays tracked.
  for (std::size_t k = found; k < t.frames.size(); ++k) {
    const Eigen::Isometry3d error = t.truth[k].inverse() * t.frames[k].pose;
    EXPECT_LT(translationNorm(error), 0.1) << k;
    EXPECT_LT(rotationAngle(error), 1 * kDeg) << k;
    EXPECT_FALSE(isFlagged(t.frames[k].status)) << k << ": " << t.frames[k].reason;
  }
}

// A long mission keeps a keyframe every 2 m: beyond resident_keyframes their scans wait on disk
// (bounded memory), and the whole map built from them and the local map rebuilt from them are the
// same bit for bit, so the kidnapped robot is found again exactly as with every scan in memory.
TEST(WholeMap, KeyframesBeyondTheResidentOnesWaitOnDiskAndGiveTheSameAnswer) {
  sim::SimulatorConfig sc;
  sc.max_frames = 40;
  const sim::Simulator sim(sc);
  OdometryConfig c = OdometryConfig::defaults();
  const Teleport all = teleport(sim, c, 34, 6, 6);
  c.recovery.resident_keyframes = 2;
  Odometry probe(sim.classTable(), c);
  for (std::size_t i = 0; i <= 34; ++i)
    probe.addFrame(sim.scan(i), i ? std::optional(sim.odometry()[i - 1].inverse() * sim.odometry()[i]) : std::nullopt);
  EXPECT_GT(probe.keyframes(), 8u);  // naraha's first 34 m
  EXPECT_EQ(probe.residentKeyframes(), 2u);
  const Teleport spilled = teleport(sim, c, 34, 6, 6);
  ASSERT_EQ(spilled.frames.size(), all.frames.size());
  std::size_t whole_map = 0;
  for (std::size_t k = 0; k < all.frames.size(); ++k) {
    EXPECT_TRUE(spilled.frames[k].pose.matrix() == all.frames[k].pose.matrix()) << k;
    EXPECT_EQ(spilled.frames[k].status, all.frames[k].status) << k;
    EXPECT_EQ(spilled.frames[k].reason, all.frames[k].reason) << k;
    whole_map += all.frames[k].global.whole_map && all.frames[k].status == FrameStatus::Relocalised;
  }
  EXPECT_GT(whole_map, 0u) << "the whole map was never used: the test proves nothing";
}

// Off, the same kidnapping is never recovered: the frames stay wrong (the test above is not
// passing by the local recovery alone).
TEST(WholeMap, WithoutItTheKidnappedRobotStaysLost) {
  sim::SimulatorConfig sc;
  sc.max_frames = 40;
  const sim::Simulator sim(sc);
  OdometryConfig c = OdometryConfig::defaults();
  c.recovery.whole_map = false;
  const Teleport t = teleport(sim, c, 34, 6, 8);
  for (std::size_t k = 35; k < t.frames.size(); ++k) {
    EXPECT_FALSE(t.frames[k].global.whole_map);
    EXPECT_GT(translationNorm(t.truth[k].inverse() * t.frames[k].pose), 1.0) << k;
  }
}

// Carried somewhere the map has never seen (corridor scans after a naraha map): the whole map is
// tried (here after the first failed frame), and nothing is accepted — no frame is relocalised
// against the wrong place.
TEST(WholeMap, AnUnknownPlaceIsNeverRelocalised) {
  sim::SimulatorConfig sc;
  sc.max_frames = 20;
  const sim::Simulator naraha(sc);
  sc.scenario = "corridor";
  const sim::Simulator corridor(sc);
  OdometryConfig c = OdometryConfig::defaults();
  c.recovery.whole_map_after = 1;
  Odometry odo(naraha.classTable(), c);
  for (std::size_t i = 0; i < 20; ++i)
    odo.addFrame(naraha.scan(i), i ? std::optional(naraha.odometry()[i - 1].inverse() * naraha.odometry()[i]) : std::nullopt);
  std::size_t whole_map_tried = 0;
  for (std::size_t i = 0; i < 8; ++i) {
    const OdometryFrame& f = odo.addFrame(corridor.scan(i), Eigen::Isometry3d::Identity());
    whole_map_tried += f.global.whole_map;
    std::printf("unknown place %zu: %s, %s\n", i, toString(f.status), (f.reason.size() > 300 ? f.reason.substr(f.reason.size() - 300) : f.reason).c_str());
    EXPECT_FALSE(f.global.whole_map && f.status == FrameStatus::Relocalised) << i << ": " << f.reason;
  }
  EXPECT_GT(whole_map_tried, 0u);
}

TEST(Relocalise, AScanWithTooFewPointsSaysSoInItsReason) {
  const ClassTable table = ClassTable::semanticKitti();
  OdometryConfig c = OdometryConfig::defaults();
  c.recovery.relocalise = true;
  Odometry odo(table, c);
  odo.addFrame(test::kittiScan(0, table));
  LabeledCloud few = test::kittiScan(1, table).slice(0, 30);
  const OdometryFrame& f = odo.addFrame(few);
  EXPECT_EQ(f.status, FrameStatus::Fallback);
  EXPECT_TRUE(f.global.tried);
  EXPECT_EQ(f.global.status, GlobalStatus::TooFewPoints) << f.reason;
  EXPECT_NE(f.reason.find("too few"), std::string::npos) << f.reason;
}

TEST(Relocalise, OffLeavesAFailedFrameAFallback) {
  const ClassTable table = ClassTable::semanticKitti();
  OdometryConfig c = OdometryConfig::defaults();
  c.recovery.relocalise = false;
  c.motion_hypotheses.enabled = false;  // they would find the start (tests/test_tracking_stress.cpp)
  Odometry odo(table, c);
  odo.addFrame(test::kittiScan(0, table));
  const OdometryFrame& f = odo.addFrame(test::kittiScan(2, table));  // 1.4 m from the identity guess
  EXPECT_EQ(f.status, FrameStatus::Fallback) << f.reason;
  EXPECT_FALSE(f.global.tried);
}

// The real KITTI sample with every second frame dropped and no odometry: frame 1 is 1.4 m from
// its identity guess (ICP diverges); recovery must find it, in agreement with the full-rate run.
// (The motion hypotheses, off here, find that start before ICP: bench_tracking_stress.)
TEST(Relocalise, KittiWithEveryOtherFrameDroppedIsTracked) {
  const ClassTable table = ClassTable::defaults();
  const auto scan = [&](int i) {
    char name[32];
    std::snprintf(name, sizeof name, "%06d.bin", i);
    return readKittiScan(test::sharedData("kitti-semantic-sample/velodyne") / name, std::nullopt, table);
  };
  OdometryConfig relocalising = OdometryConfig::defaults();
  relocalising.recovery.relocalise = true;
  relocalising.motion_hypotheses.enabled = false;
  Odometry full(table), dropped(table, relocalising);
  for (int i = 0; i < 6; ++i) full.addFrame(scan(i));
  for (int i = 0; i < 6; i += 2) {
    const OdometryFrame& f = dropped.addFrame(scan(i));
    EXPECT_NE(f.status, FrameStatus::Fallback) << "frame " << i << ": " << f.reason;
  }
  EXPECT_EQ(dropped.frames()[1].status, FrameStatus::Relocalised) << dropped.frames()[1].reason;
  for (std::size_t k = 1; k < 3; ++k) {
    const Eigen::Isometry3d want = full.frames()[2 * k - 2].pose.inverse() * full.frames()[2 * k].pose;
    const Eigen::Isometry3d got = dropped.frames()[k - 1].pose.inverse() * dropped.frames()[k].pose;
    EXPECT_GT(translationNorm(want), 1.0);
    EXPECT_LT(translationNorm(want.inverse() * got), 0.05) << k;
    EXPECT_LT(rotationAngle(want.inverse() * got), 0.5 * kDeg) << k;
  }
}

TEST(Relocalise, OusterOs1128CaptureIsTrackedFrameByFrame) {
  const auto out = test::scratchDir();
  const auto r = test::runCli("odometry " + test::sharedData("sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3.pcap").string() +
                              " --quiet --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto s = nlohmann::json::parse(readTextFile(out / "summary.json"));
  EXPECT_EQ(s["frames"].get<int>(), 3);
  EXPECT_EQ(s["fallbacks"].get<int>(), 0) << s.dump();
  EXPECT_EQ(s["tracked_frames"].get<int>() + s["relocalised_frames"].get<int>(), 3);
}

}  // namespace
}  // namespace hazmap
