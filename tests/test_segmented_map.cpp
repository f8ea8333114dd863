// GlobalMap::insertMap and SegmentedMap: a map re-placed segment by segment after corrections
// equals the map rebuilt from every scan (exactly where nothing moved, within a cell otherwise).
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <random>
#include <thread>

#include "hazmap/core/error.hpp"
#include "hazmap/map/global_map.hpp"
#include "hazmap/map/hazards.hpp"
#include "hazmap/map/segmented_map.hpp"
#include "map_agreement.hpp"

using namespace hazmap;

namespace {

constexpr ClassId kNone = 0, kHeat = 1, kWater = 2;

// A room 30 × 6 × 3 m of random surface points, a hot wall patch and a wet floor patch.
struct World {
  std::vector<Eigen::Vector3d> points;
  std::vector<ClassId> classes;
  std::vector<float> heat;
  World() {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0, 1);
    for (int k = 0; k < 80000; ++k) {
      const double x = 30 * u(rng), s = u(rng);
      // Surfaces off the cell faces (0.1 m cells), as real ones are.
      Eigen::Vector3d p = s < 0.4 ? Eigen::Vector3d(x, 6 * u(rng), 0.013) : s < 0.7 ? Eigen::Vector3d(x, 0.037, 3 * u(rng))
                                                                                 : Eigen::Vector3d(x, 5.961, 3 * u(rng));
      ClassId c = kNone;
      if (s >= 0.4 && s < 0.7 && x > 10 && x < 12 && p.z() < 1.5) c = kHeat;
      if (s < 0.4 && x > 18 && x < 21 && p.y() > 2 && p.y() < 4) c = kWater;
      points.push_back(p);
      classes.push_back(c);
      heat.push_back(c == kHeat ? float(60 + 10 * u(rng)) : std::nanf(""));
    }
  }
};

Eigen::Isometry3d poseAt(std::size_t i) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(1.0 + 0.1 * double(i), 3.0 + 0.3 * std::sin(0.05 * double(i)), 0.5);
  T.linear() = Eigen::AngleAxisd(0.02 * std::sin(0.1 * double(i)), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

// What the sensor at `T` sees within 8 m, in its own frame, with a heat channel.
struct Frame {
  LabeledCloud cloud;
  std::vector<PointChannel> channels;
};
Frame scanAt(const World& w, const Eigen::Isometry3d& T) {
  Frame f;
  f.cloud.enableProperty();
  f.channels.push_back({"heat_c", {}});
  const Eigen::Isometry3d inv = T.inverse();
  for (std::size_t k = 0; k < w.points.size(); ++k) {
    if ((w.points[k] - T.translation()).norm() > 8) continue;
    const float heat = w.heat[k];
    f.cloud.push_back((inv * w.points[k]).cast<float>(), w.classes[k], 0.0f, 0.0, std::isfinite(heat) ? heat : 0.0f);
    f.channels[0].values.push_back(heat);
  }
  return f;
}

void expectSameCells(const GlobalMap& a, const GlobalMap& b, float centroid_tolerance) {
  const std::vector<MapCell> ca = a.cells(), cb = b.cells();
  ASSERT_EQ(ca.size(), cb.size());
  EXPECT_EQ(a.frames(), b.frames());
  EXPECT_EQ(a.pointsInserted(), b.pointsInserted());
  for (std::size_t i = 0; i < ca.size(); ++i) {
    ASSERT_EQ(ca[i].index, cb[i].index) << "cell " << i;
    EXPECT_LE((ca[i].centroid - cb[i].centroid).norm(), centroid_tolerance) << "cell " << i;
    EXPECT_EQ(ca[i].points, cb[i].points);
    EXPECT_EQ(ca[i].label, cb[i].label);
    EXPECT_EQ(ca[i].label_points, cb[i].label_points);
    EXPECT_EQ(ca[i].property_samples, cb[i].property_samples);
    EXPECT_NEAR(ca[i].property_mean, cb[i].property_mean, 1e-3f);
    EXPECT_EQ(ca[i].property_max, cb[i].property_max);
    EXPECT_EQ(ca[i].frames, cb[i].frames);
    EXPECT_EQ(ca[i].frame_count, cb[i].frame_count);
    ASSERT_EQ(ca[i].channels.size(), cb[i].channels.size());
    for (std::size_t k = 0; k < ca[i].channels.size(); ++k) {
      EXPECT_NEAR(ca[i].channels[k].mean, cb[i].channels[k].mean, 1e-3f);
      EXPECT_EQ(ca[i].channels[k].max, cb[i].channels[k].max);
      EXPECT_EQ(ca[i].channels[k].samples, cb[i].channels[k].samples);
    }
  }
}

// The map of frames 0 … n − 1 at `poses`, every scan inserted: what a run's second pass builds.
GlobalMap rebuilt(const World& w, std::size_t n, const std::vector<Eigen::Isometry3d>& scan_poses,
                  const std::vector<Eigen::Isometry3d>& poses) {
  GlobalMap map;
  for (std::size_t i = 0; i < n; ++i) {
    const Frame f = scanAt(w, scan_poses[i]);
    map.insert(i, f.cloud, poses[i], f.channels);
  }
  return map;
}

// For each cell of `a`, the distance to the nearest centroid of `b` within two cells: the largest.
double farthestCentroid(const GlobalMap& a, const GlobalMap& b) {
  const std::vector<double> d = test::nearestCentroidDistances(a, b, 2, 1e9);
  return d.empty() ? 0.0 : *std::max_element(d.begin(), d.end());
}

std::vector<Eigen::Isometry3d> truePoses(std::size_t n) {
  std::vector<Eigen::Isometry3d> poses;
  for (std::size_t i = 0; i < n; ++i) poses.push_back(poseAt(i));
  return poses;
}

}  // namespace

TEST(GlobalMapInsertMap, UnmovedPartsAddUpToTheMapOfEveryScan) {
  const World w;
  const auto poses = truePoses(30);
  GlobalMap first, second, whole;
  for (std::size_t i = 0; i < 30; ++i) {
    const Frame f = scanAt(w, poses[i]);
    (i < 17 ? first : second).insert(i, f.cloud, poses[i], f.channels);
  }
  whole.insertMap(first, Eigen::Isometry3d::Identity());
  whole.insertMap(second, Eigen::Isometry3d::Identity());
  const GlobalMap expected = rebuilt(w, 30, poses, poses);
  expectSameCells(whole, expected, 1e-4f);
  EXPECT_EQ(whole.channelNames(), std::vector<std::string>{"heat_c"});
  EXPECT_GT(whole.size(), 1000u);
}

TEST(GlobalMapInsertMap, AMovedPartLandsWithinACellOfItsPoints) {
  const World w;
  const auto poses = truePoses(20);
  GlobalMap part = rebuilt(w, 20, poses, poses);
  Eigen::Isometry3d move = Eigen::Isometry3d::Identity();
  move.translation() = Eigen::Vector3d(0.37, -0.21, 0.05);
  move.linear() = Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  GlobalMap moved;
  moved.insertMap(part, move);
  std::vector<Eigen::Isometry3d> moved_poses;
  for (const auto& p : poses) moved_poses.push_back(move * p);
  const GlobalMap expected = rebuilt(w, 20, poses, moved_poses);
  // Counts are kept; a cell lands whole where its centroid goes: every centroid within a cell's
  // diagonal (0.1 m cells) of one of the map rebuilt from the moved scans, and the other way.
  EXPECT_EQ(moved.pointsInserted(), expected.pointsInserted());
  EXPECT_EQ(moved.frames(), expected.frames());
  EXPECT_LE(farthestCentroid(moved, expected), 0.1 * std::sqrt(3.0));
  EXPECT_LE(farthestCentroid(expected, moved), 0.1 * std::sqrt(3.0));
  // Each of the part's cells lands whole in one cell; where two would share one, the later goes
  // across the nearest face if that is free: (almost) every cell kept. (How many cells the
  // rebuilt map has depends on how its surfaces lie in the grid, not a yardstick here.)
  EXPECT_LE(moved.size(), part.size());
  EXPECT_GE(double(moved.size()), 0.9 * double(part.size()));
  // The hazards (the hot wall) are found where the rebuilt map has them.
  const std::vector<Hazard> found = findHazards(moved), rebuilt_hazards = findHazards(expected);
  ASSERT_EQ(found.size(), rebuilt_hazards.size());
  ASSERT_GE(found.size(), 1u);
  for (std::size_t k = 0; k < found.size(); ++k) {
    EXPECT_EQ(found[k].label, rebuilt_hazards[k].label);
    EXPECT_LE((found[k].centroid - rebuilt_hazards[k].centroid).norm(), 0.05);
    EXPECT_NEAR(found[k].area_m2, rebuilt_hazards[k].area_m2, 0.1 * rebuilt_hazards[k].area_m2);
  }
}

TEST(GlobalMapInsertMap, RefusesANonFiniteMoveAndAnotherClassTable) {
  GlobalMap map, part;
  Eigen::Isometry3d bad = Eigen::Isometry3d::Identity();
  bad.translation().x() = std::nan("");
  EXPECT_THROW(map.insertMap(part, bad), Error);
  ClassTable other = ClassTable::defaults();
  other.add({77, "other", PropertyKind::None});
  GlobalMap foreign(GlobalMapConfig{}, other);
  EXPECT_THROW(map.insertMap(foreign, Eigen::Isometry3d::Identity()), Error);
}

TEST(SegmentedMap, WithoutCorrectionsItComposesTheMapOfEveryScan) {
  const World w;
  const auto poses = truePoses(130);
  SegmentedMap segments(GlobalMapConfig{}, ClassTable::defaults());
  for (std::size_t i = 0; i < 130; ++i) {
    const Frame f = scanAt(w, poses[i]);
    segments.add(i, f.cloud, f.channels, poses, 25);
  }
  segments.close();
  EXPECT_EQ(segments.segments(), 6u);  // 5 × 25 + 5
  expectSameCells(segments.compose(130, poses), rebuilt(w, 130, poses, poses), 1e-4f);
}

TEST(SegmentedMap, ACorrectionMovesEachSegmentWithItsAnchor) {
  // Tracking drifts (a yaw rate error); a loop correction at frame 100 puts every frame at its
  // true pose. The segments, built at the drifted poses, are re-placed by their anchors.
  const World w;
  const std::size_t n = 160;
  const auto truth = truePoses(n);
  std::vector<Eigen::Isometry3d> drifted = truth;
  for (std::size_t i = 0; i < n; ++i) {
    const double s = 0.1 * double(i);
    drifted[i] = Eigen::Translation3d(0, 0.001 * s * s, 0) * Eigen::AngleAxisd(0.004 * s, Eigen::Vector3d::UnitZ()) *
                 truth[i];
  }
  const GlobalMap expected = rebuilt(w, n, truth, truth);
  // Segments of 10 frames begin at the correction; of 15, frames 100-104 join the segment that
  // began at frame 90 before it, placed where they lie relative to its anchor now.
  for (const std::size_t frames_per_segment : {10, 15}) {
    SegmentedMap segments(GlobalMapConfig{}, ClassTable::defaults());
    for (std::size_t i = 0; i < n; ++i) {  // from frame 100 on every pose is corrected
      const Frame f = scanAt(w, truth[i]);
      segments.add(i, f.cloud, f.channels, i < 100 ? drifted : truth, frames_per_segment);
    }
    segments.close();
    const GlobalMap composed = segments.compose(n, truth);
    EXPECT_EQ(composed.pointsInserted(), expected.pointsInserted());
    // Within a segment the drift (about the world's origin, ~10 m away) changes by up to ~6 cm
    // (10 frames) or ~9 cm (15): every cell within that and a cell of the rebuilt map's.
    const double within = frames_per_segment == 10 ? 0.15 : 0.18;
    EXPECT_LE(farthestCentroid(composed, expected), within) << frames_per_segment;
    EXPECT_LE(farthestCentroid(expected, composed), within) << frames_per_segment;
  }
  // Rebuilt from the drifted poses instead, the map would be off by the drift (metres).
  GlobalMap stale;
  for (std::size_t i = 0; i < n; ++i) {
    const Frame f = scanAt(w, truth[i]);
    stale.insert(i, f.cloud, drifted[i], f.channels);
  }
  EXPECT_GT(farthestCentroid(stale, expected), 0.25);
}

TEST(SegmentedMap, SteadyNeighboursMergeAndTheMapStaysTheSame) {
  const World w;
  const std::size_t n = 100;
  const auto poses = truePoses(n);
  SegmentedMapConfig c;
  c.max_segments = 100;
  SegmentedMap segments(GlobalMapConfig{}, ClassTable::defaults(), c);
  for (std::size_t i = 0; i < 60; ++i) {
    const Frame f = scanAt(w, poses[i]);
    segments.add(i, f.cloud, f.channels, poses, 10);
  }
  segments.close();
  const GlobalMap first = segments.compose(60, poses);
  EXPECT_EQ(segments.segments(), 6u);  // nothing seen twice yet
  // Frames 60 … 99 arrive after a correction that moved frames 30 … 59 by 0.5 m.
  std::vector<Eigen::Isometry3d> moved = poses;
  for (std::size_t i = 30; i < n; ++i) moved[i] = Eigen::Translation3d(0.5, 0, 0) * poses[i];
  for (std::size_t i = 60; i < n; ++i) {
    const Frame f = scanAt(w, poses[i]);
    segments.add(i, f.cloud, f.channels, moved, 10);
  }
  segments.close();
  const GlobalMap second = segments.compose(n, moved);
  // 0-29 steady since the last compose: one segment; 30-59 moved against it but alike among
  // themselves: one; 60-99 not seen before: four.
  EXPECT_EQ(segments.segments(), 6u);
  const GlobalMap third = segments.compose(n, moved);
  EXPECT_EQ(segments.segments(), 1u);  // nothing moved since: all steady
  expectSameCells(second, third, 1e-4f);
  EXPECT_EQ(first.frames(), 60u);
  EXPECT_EQ(third.frames(), n);
}

TEST(SegmentedMap, TooManySegmentsMergeTheSteadiest) {
  const World w;
  const auto poses = truePoses(40);
  SegmentedMapConfig c;
  c.max_segments = 8;
  SegmentedMap segments(GlobalMapConfig{}, ClassTable::defaults(), c);
  for (std::size_t i = 0; i < 40; ++i) {
    const Frame f = scanAt(w, poses[i]);
    segments.add(i, f.cloud, f.channels, poses, 1);  // a segment per frame
  }
  segments.close();
  EXPECT_EQ(segments.segments(), 40u);
  const GlobalMap map = segments.compose(40, poses);
  EXPECT_EQ(segments.segments(), 8u);
  expectSameCells(map, rebuilt(w, 40, poses, poses), 1e-4f);
}

TEST(SegmentedMap, ComposesOnlyAtACutAndTakesFramesInOrder) {
  const World w;
  const auto poses = truePoses(12);
  SegmentedMap segments(GlobalMapConfig{}, ClassTable::defaults());
  for (std::size_t i = 0; i < 12; ++i) {
    const Frame f = scanAt(w, poses[i]);
    segments.add(i, f.cloud, f.channels, poses, 100);
  }
  EXPECT_THROW(segments.compose(12, poses), Error);  // the open segment is not composed
  segments.close();
  EXPECT_THROW(segments.compose(7, poses), Error);  // no cut at frame 7
  EXPECT_THROW(segments.compose(12, std::span(poses).first(11)), Error);
  EXPECT_EQ(segments.compose(12, poses).frames(), 12u);
  EXPECT_EQ(segments.compose(0, poses).size(), 0u);
  const Frame f = scanAt(w, poses[0]);
  EXPECT_THROW(segments.add(14, f.cloud, f.channels, poses[0], 14, poses[0]), Error);  // frame 12 is next
  EXPECT_THROW(segments.add(12, f.cloud, f.channels, poses[0], 3, poses[3]), Error);   // no segment begins at 3
  SegmentedMapConfig one;
  one.max_segments = 1;
  EXPECT_THROW(SegmentedMap(GlobalMapConfig{}, ClassTable::defaults(), one), Error);
}

TEST(SegmentedMap, OneThreadAddsWhileAnotherComposesItsCuts) {
  const World w;
  const std::size_t n = 120;
  const auto poses = truePoses(n);
  std::vector<Frame> frames;
  for (std::size_t i = 0; i < n; ++i) frames.push_back(scanAt(w, poses[i]));
  SegmentedMap segments(GlobalMapConfig{}, ClassTable::defaults());
  std::atomic<std::size_t> cut{0};
  std::thread adder([&] {
    for (std::size_t i = 0; i < n; ++i) {
      segments.add(i, frames[i].cloud, frames[i].channels, poses, 7);
      if (i % 20 == 19) {
        segments.close();
        cut = i + 1;
      }
    }
  });
  std::size_t composed = 0;
  while (composed < n) {
    const std::size_t at = cut.load();
    if (at == composed) {
      std::this_thread::yield();
      continue;
    }
    EXPECT_EQ(segments.compose(at, poses).frames(), at);
    composed = at;
  }
  adder.join();
  expectSameCells(segments.compose(n, poses), rebuilt(w, n, poses, poses), 1e-4f);
}
