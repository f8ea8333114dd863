// hazmap::stableSortAligned (include/hazmap/core/stable_sort.hpp): std::stable_sort's order for
// element types holding fixed-size vectorisable Eigen members, without std::stable_sort's 16-byte
// scratch buffer (issue 37, part 4: the -march=native crash in global registration's
// sortAndThin). What CI cannot see at run time in the default build (there such types need only
// 16 bytes) scripts/check-alignment.sh checks at compile time, as for AVX-512 (ctest
// alignment_check).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "hazmap/core/stable_sort.hpp"
#include "hazmap/loop/candidates.hpp"

using namespace hazmap;

namespace {

struct Plain {
  int key = 0;
  int id = 0;
};

// Over-aligned in every build (64 bytes, as Eigen aligns a Matrix4d under AVX-512).
struct alignas(64) Wide {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  int key = 0;
  int id = 0;
};

bool aligned(const void* p, std::size_t a) { return reinterpret_cast<std::uintptr_t>(p) % a == 0; }

TEST(StableSortAligned, SameOrderAsStdStableSortWithManyTies) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> key(0, 9);  // 300 elements, 10 keys: ties everywhere
  std::vector<Plain> plain(300);
  std::vector<Wide> wide(300);
  for (int i = 0; i < 300; ++i) {
    plain[i] = {key(rng), i};
    wide[i].key = plain[i].key;
    wide[i].id = i;
    wide[i].T.translation() = Eigen::Vector3d(i, -i, 0.5 * i);
  }
  std::stable_sort(plain.begin(), plain.end(), [](const Plain& a, const Plain& b) { return a.key > b.key; });
  stableSortAligned(wide, [](const Wide& a, const Wide& b) { return a.key > b.key; });
  ASSERT_EQ(wide.size(), plain.size());
  for (std::size_t i = 0; i < wide.size(); ++i) {
    EXPECT_EQ(wide[i].id, plain[i].id) << "position " << i;
    EXPECT_EQ(wide[i].T.translation().x(), double(plain[i].id)) << "the element moved whole";
  }
}

TEST(StableSortAligned, ComparesAndStoresOnlyAlignedElements) {
  std::vector<Wide> v(257);
  for (int i = 0; i < 257; ++i) v[i].key = (i * 37) % 11;
  bool all_aligned = true;
  stableSortAligned(v, [&](const Wide& a, const Wide& b) {
    all_aligned = all_aligned && aligned(&a, alignof(Wide)) && aligned(&b, alignof(Wide));
    return a.key < b.key;
  });
  EXPECT_TRUE(all_aligned);
  EXPECT_TRUE(aligned(v.data(), alignof(Wide)));
  EXPECT_TRUE(std::is_sorted(v.begin(), v.end(), [](const Wide& a, const Wide& b) { return a.key < b.key; }));
}

TEST(StableSortAligned, EmptyAndSingle) {
  std::vector<Wide> none;
  stableSortAligned(none, [](const Wide& a, const Wide& b) { return a.key < b.key; });
  EXPECT_TRUE(none.empty());
  std::vector<Wide> one(1);
  one[0].id = 5;
  stableSortAligned(one, [](const Wide& a, const Wide& b) { return a.key < b.key; });
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].id, 5);
}

// Through the loop stage's public API (one of the four call sites): keyframes at equal distances
// from the query stay in index order, nearest first, each with its own initial guess.
TEST(StableSortAligned, DistanceCandidatesNearestFirstTiesInIndexOrder) {
  PoseList poses(40, Eigen::Isometry3d(Eigen::Translation3d(100.0, 0.0, 0.0)));
  poses[39] = Eigen::Isometry3d::Identity();  // the query, at the origin
  const double d[] = {2.0, 1.0, 2.0, 0.5, 1.0, 2.0, 0.5, 2.5, 1.0, 2.0};
  for (std::size_t j = 0; j < 10; ++j) poses[j].translation() = Eigen::Vector3d(d[j], 0.0, 0.0);
  CandidateSearchConfig config;
  config.max_candidates = 10;
  const auto out = findDistanceCandidates(39, poses, config);
  const std::vector<std::size_t> expected = {3, 6, 1, 4, 8, 0, 2, 5, 9, 7};
  ASSERT_EQ(out.size(), expected.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(out[i].match, expected[i]) << "rank " << i;
    EXPECT_DOUBLE_EQ(out[i].initial_guess.translation().x(), -d[expected[i]]);
    EXPECT_TRUE(aligned(&out[i].initial_guess, alignof(Eigen::Isometry3d)));
  }
}

}  // namespace
