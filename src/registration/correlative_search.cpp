#include "hazmap/registration/correlative_search.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <numeric>
#include <unordered_map>

namespace hazmap {

namespace {

// The structure is a slice of the scene like a 2-D laser's: above the floor by more than
// kSliceLow (floor returns and their noise), below kSliceHigh (ceilings cover everything).
constexpr double kSliceLow = 0.3, kSliceHigh = 2.0;
// The structure's fields, fine to rough: cell and σ (m). Labels are coarser than geometry.
constexpr double kCell[3] = {0.1, 0.4, 1.0}, kSigma[3] = {0.15, 0.4, 0.8};
constexpr double kLabelCell = 0.2, kLabelSigma = 0.5;
// Labelled patches: cells of kLabelCluster m where a property class holds kLabelShare of the points.
constexpr double kLabelCluster = 0.5, kLabelShare = 0.3;
constexpr std::size_t kLabelMinPoints = 3;
// A pyramid: every place (rough cells) and heading (kYawDeg[2]) on the rough field; the
// kSeeds best distinct of those searched again within one rough step on the middle field; the
// kRefined best distinct of those within one middle step on the fine one. Each level's steps are
// its cell and kYawDeg; its query is thinned to its cell (at most kMaxQueryStructure points).
constexpr double kYawDeg[3] = {1.0, 3.0, 6.0};
constexpr std::size_t kSeeds = 32, kRefined = 8;
constexpr double kSeedDistinctMetres = 2.0, kSeedDistinctDeg = 12.0;
constexpr std::size_t kMaxQueryStructure = 800, kMinQueryStructure = 50, kMinQueryLabels = 5;
// A place this far from the best is another answer; within this share of its score, a twin.
constexpr double kDistinctMetres = 1.5, kDistinctDeg = 15.0, kMaxAmbiguity = 0.9;
// Labels choose among twins only with this much support (mean label field value) and this lead.
constexpr double kMinLabelSupport = 0.1, kLabelLead = 2.0;
constexpr double kDeg = M_PI / 180.0;

// The square of `cell` m holding (x, y), as one hash key.
long long cellKey(double x, double y, double cell) {
  return (static_cast<long long>(std::floor(x / cell)) << 32) ^ (static_cast<long long>(std::floor(y / cell)) & 0xffffffffLL);
}

double floorBelow(const LabeledCloud& cloud, double below) {
  std::unordered_map<long, std::size_t> bands;
  for (const auto& p : cloud.points)
    if (std::isfinite(p.z()) && p.z() < below) ++bands[std::lround(std::floor(p.z() / 0.1))];
  if (bands.empty()) return below;
  const auto best = std::max_element(bands.begin(), bands.end(), [](const auto& a, const auto& b) {
    return a.second != b.second ? a.second < b.second : a.first > b.first;
  });
  return (static_cast<double>(best->first) + 0.5) * 0.1;
}

std::vector<Eigen::Vector2d> slice(const LabeledCloud& cloud, double floor_z) {
  std::vector<Eigen::Vector2d> out;
  for (const auto& p : cloud.points)
    if (p.allFinite() && p.z() > floor_z + kSliceLow && p.z() < floor_z + kSliceHigh) out.emplace_back(p.x(), p.y());
  return out;
}

// Property-class points in the cells (kLabelCluster m) where their class is at least
// kLabelShare of all the points and has kLabelMinPoints: a hazard is a patch, while false labels
// (a hot pixel, the simulator's 0.5 %) are scattered — and accumulate over many scans into
// clusters of their own, but never into a share of the surface.
std::vector<std::pair<ClassId, std::vector<Eigen::Vector2d>>> labelPatches(const LabeledCloud& cloud,
                                                                           const ClassTable& classes) {
  const auto key = [](const Eigen::Vector3f& p) { return cellKey(p.x(), p.y(), kLabelCluster); };
  std::unordered_map<long long, std::size_t> all;
  std::unordered_map<ClassId, std::unordered_map<long long, std::size_t>> of_class;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.points[i].allFinite()) continue;
    const long long k = key(cloud.points[i]);
    ++all[k];
    if (classes.isProperty(cloud.classes[i])) ++of_class[cloud.classes[i]][k];
  }
  std::vector<std::pair<ClassId, std::vector<Eigen::Vector2d>>> out;
  for (const auto& [cls, cells] : of_class) {
    std::vector<Eigen::Vector2d> kept;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (cloud.classes[i] != cls || !cloud.points[i].allFinite()) continue;
      const long long k = key(cloud.points[i]);
      const std::size_t n = cells.at(k);
      if (n >= kLabelMinPoints && static_cast<double>(n) >= kLabelShare * static_cast<double>(all.at(k)))
        kept.emplace_back(cloud.points[i].x(), cloud.points[i].y());
    }
    if (!kept.empty()) out.emplace_back(cls, std::move(kept));
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return out;
}

CorrelativeTarget::Field makeField(const std::vector<Eigen::Vector2d>& pts, double cell, double sigma) {
  CorrelativeTarget::Field f;
  if (pts.empty()) return f;
  Eigen::Vector2d lo = pts.front(), hi = pts.front();
  for (const auto& p : pts) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const double reach = 3.0 * sigma;
  f.cell = cell;
  f.x0 = lo.x() - reach, f.y0 = lo.y() - reach;
  f.nx = static_cast<int>(std::ceil((hi.x() - lo.x() + 2 * reach) / cell)) + 1;
  f.ny = static_cast<int>(std::ceil((hi.y() - lo.y() + 2 * reach) / cell)) + 1;
  f.value.assign(static_cast<std::size_t>(f.nx) * f.ny, 0.0f);
  const int r = static_cast<int>(std::ceil(reach / cell));
  for (const auto& p : pts) {
    const int cx = static_cast<int>((p.x() - f.x0) / cell), cy = static_cast<int>((p.y() - f.y0) / cell);
    for (int y = std::max(0, cy - r); y <= std::min(f.ny - 1, cy + r); ++y)
      for (int x = std::max(0, cx - r); x <= std::min(f.nx - 1, cx + r); ++x) {
        const double d2 = (Eigen::Vector2d(f.x0 + (x + 0.5) * cell, f.y0 + (y + 0.5) * cell) - p).squaredNorm();
        if (d2 > reach * reach) continue;
        float& v = f.value[static_cast<std::size_t>(y) * f.nx + x];
        v = std::max(v, static_cast<float>(std::exp(-0.5 * d2 / (sigma * sigma))));
      }
  }
  return f;
}

// At most `n` of `pts`, one per `cell`-sized square, evenly strided.
std::vector<Eigen::Vector2d> thinned(const std::vector<Eigen::Vector2d>& pts, double cell, std::size_t n) {
  std::unordered_map<long long, Eigen::Vector2d> one;
  std::vector<long long> order;
  for (const auto& p : pts) {
    const long long k = cellKey(p.x(), p.y(), cell);
    if (one.emplace(k, p).second) order.push_back(k);
  }
  std::sort(order.begin(), order.end());
  std::vector<Eigen::Vector2d> out;
  const std::size_t stride = std::max<std::size_t>(1, (order.size() + n - 1) / n);
  for (std::size_t i = 0; i < order.size(); i += stride) out.push_back(one[order[i]]);
  return out;
}

struct Pose2 {
  double x = 0.0, y = 0.0, yaw = 0.0;
};

bool distinct(const Pose2& a, const Pose2& b, double metres = kDistinctMetres, double degrees = kDistinctDeg) {
  const double dyaw = std::abs(std::remainder(a.yaw - b.yaw, 2.0 * M_PI));
  return std::hypot(a.x - b.x, a.y - b.y) >= metres || dyaw >= degrees * kDeg;
}

struct Query {
  std::vector<Eigen::Vector2d> thinner[3];  ///< the slice per pyramid level (0: fine)
  std::vector<std::pair<const CorrelativeTarget::Field*, std::vector<Eigen::Vector2d>>> labels;
  std::size_t label_points = 0;
};

// The mean structure field value of a query's slice `pts` placed at T.
double structureScore(const std::vector<Eigen::Vector2d>& pts, const CorrelativeTarget::Field& field, const Pose2& T) {
  const double c = std::cos(T.yaw), s = std::sin(T.yaw);
  double sum = 0.0;
  for (const auto& p : pts) sum += field.at(c * p.x() - s * p.y() + T.x, s * p.x() + c * p.y() + T.y);
  return sum / static_cast<double>(pts.size());
}

// The mean label field value of the query's labelled patches placed at T (each on its class's).
double labelShare(const Query& q, const Pose2& T) {
  if (q.label_points == 0) return 0.0;
  const double c = std::cos(T.yaw), s = std::sin(T.yaw);
  double sum = 0.0;
  for (const auto& [f, pts] : q.labels)
    if (f)
      for (const auto& p : pts) sum += f->at(c * p.x() - s * p.y() + T.x, s * p.x() + c * p.y() + T.y);
  return sum / static_cast<double>(q.label_points);
}

// The best place within one step of level `level + 1` around `centre`, in level `level`'s steps.
std::pair<double, Pose2> searchAround(const Query& q, const CorrelativeTarget& target, int level, const Pose2& centre) {
  const int steps = static_cast<int>(std::lround(kCell[level + 1] / kCell[level]));
  const int yaw_steps = static_cast<int>(std::lround(kYawDeg[level + 1] / kYawDeg[level]));
  std::pair<double, Pose2> best{-1.0, centre};
  for (int a = -yaw_steps; a <= yaw_steps; ++a)
    for (int i = -steps; i <= steps; ++i)
      for (int j = -steps; j <= steps; ++j) {
        const Pose2 T{centre.x + i * kCell[level], centre.y + j * kCell[level], centre.yaw + a * kYawDeg[level] * kDeg};
        const double sc = structureScore(q.thinner[level], target.structure(level), T);
        if (sc > best.first) best = {sc, T};
      }
  return best;
}

// The `n` best of `scored` (best first) that are pairwise distinct by (metres, degrees).
std::vector<std::pair<double, Pose2>> bestDistinct(std::vector<std::pair<double, Pose2>> scored, std::size_t n,
                                                   double metres, double degrees) {
  std::stable_sort(scored.begin(), scored.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::pair<double, Pose2>> out;
  for (const auto& c : scored) {
    if (!std::all_of(out.begin(), out.end(), [&](const auto& o) { return distinct(o.second, c.second, metres, degrees); }))
      continue;
    out.push_back(c);
    if (out.size() == n) break;
  }
  return out;
}

// The rough cells within `radius` of any place, sorted (deterministic).
std::vector<Eigen::Vector2d> candidatePlaces(const std::vector<Eigen::Vector2d>& places, double radius) {
  std::vector<std::pair<long long, long long>> cells;
  const double cell = kCell[2];
  const int r = static_cast<int>(std::ceil(radius / cell));
  for (const auto& p : places) {
    const long long cx = std::llround(p.x() / cell), cy = std::llround(p.y() / cell);
    for (int dx = -r; dx <= r; ++dx)
      for (int dy = -r; dy <= r; ++dy)
        if (std::hypot(dx, dy) * cell <= radius) cells.emplace_back(cx + dx, cy + dy);
  }
  std::sort(cells.begin(), cells.end());
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  std::vector<Eigen::Vector2d> out;
  for (const auto& [x, y] : cells) out.emplace_back(x * cell, y * cell);
  return out;
}

// The answer among the refined places (best structure first): the structure's best, unless
// places distinct from it fit the structure within kMaxAmbiguity of it — a repeated layout's
// twins — when the query's labelled patches must pick one: the twin with the most label support,
// if it has at least kMinLabelSupport and kLabelLead times any other's. Labels never outvote the
// structure: a hazard that moved since (a heat source 2 m further) would otherwise drag the answer.
CorrelativeResult decide(const Query& q, const std::vector<std::pair<double, Pose2>>& refined, double dz,
                         CorrelativeResult r) {
  const double best_structure = refined.front().first;
  std::vector<std::pair<double, Pose2>> twins;  // label share, place
  for (const auto& [sc, p] : refined)
    if (sc >= kMaxAmbiguity * best_structure &&
        std::all_of(twins.begin(), twins.end(), [&](const auto& t) { return distinct(t.second, p); }))
      twins.emplace_back(labelShare(q, p), p);
  Pose2 best = refined.front().second;
  r.score = best_structure;
  r.second_score = 0.0;
  for (const auto& [sc, p] : refined)
    if (distinct(p, best)) {
      r.second_score = sc;
      break;
    }
  if (twins.size() > 1) {
    std::stable_sort(twins.begin(), twins.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    const double lead = twins[0].first, next = twins[1].first;
    if (q.label_points < kMinQueryLabels || lead < kMinLabelSupport || lead < kLabelLead * next) {
      r.reason = fmt::format("ambiguous: {} places fit the structure within {:.0f} % ({:.2f}); labelled points {}, "
                             "label support {:.2f} / {:.2f}", twins.size(), 100.0 * (1.0 - kMaxAmbiguity),
                             best_structure, q.label_points, lead, next);
      return r;
    }
    best = twins[0].second;
    r.reason = fmt::format("{} places fit the structure within {:.0f} %; the labels chose one (support {:.2f}, next "
                           "{:.2f}); ", twins.size(), 100.0 * (1.0 - kMaxAmbiguity), lead, next);
  }
  r.transform = Eigen::Translation3d(best.x, best.y, dz) * Eigen::AngleAxisd(best.yaw, Eigen::Vector3d::UnitZ());
  r.success = true;
  r.reason += fmt::format("structure {:.2f}, next distinct place {:.2f} ({} structure, {} labelled points)", r.score,
                          r.second_score, q.thinner[0].size(), q.label_points);
  return r;
}

}  // namespace

float CorrelativeTarget::Field::at(double x, double y) const {
  const int cx = static_cast<int>(std::floor((x - x0) / cell)), cy = static_cast<int>(std::floor((y - y0) / cell));
  if (cx < 0 || cy < 0 || cx >= nx || cy >= ny) return 0.0f;
  return value[static_cast<std::size_t>(cy) * nx + cx];
}

CorrelativeTarget::CorrelativeTarget(const LabeledCloud& cloud, double sensor_z, const ClassTable& classes) {
  floor_z_ = floorBelow(cloud, sensor_z);
  const std::vector<Eigen::Vector2d> s = slice(cloud, floor_z_);
  for (int level = 0; level < 3; ++level) structure_[level] = makeField(s, kCell[level], kSigma[level]);
  for (const auto& [cls, pts] : labelPatches(cloud, classes)) labels_.emplace_back(cls, makeField(pts, kLabelCell, kLabelSigma));
}

const CorrelativeTarget::Field* CorrelativeTarget::labels(ClassId cls) const {
  for (const auto& [c, f] : labels_)
    if (c == cls) return &f;
  return nullptr;
}

CorrelativeResult searchCorrelative(const LabeledCloud& query_cloud, const CorrelativeTarget& target,
                                    const std::vector<Eigen::Vector2d>& places, double place_radius,
                                    const ClassTable& classes) {
  CorrelativeResult r;
  if (target.empty() || places.empty()) {
    r.reason = "the target has no structure above its floor";
    return r;
  }
  const double query_floor = floorBelow(query_cloud, 0.0);
  Query q;
  const std::vector<Eigen::Vector2d> sliced = slice(query_cloud, query_floor);
  for (int level = 0; level < 3; ++level) q.thinner[level] = thinned(sliced, std::max(kCell[level], 0.2), kMaxQueryStructure);
  for (const auto& [cls, pts] : labelPatches(query_cloud, classes)) {
    q.labels.emplace_back(target.labels(cls), thinned(pts, kLabelCell, kMaxQueryStructure));
    q.label_points += q.labels.back().second.size();
  }
  r.structure_points = q.thinner[0].size();
  r.label_points = q.label_points;
  if (r.structure_points < kMinQueryStructure) {
    r.reason = fmt::format("{} structure points above the floor (< {})", r.structure_points, kMinQueryStructure);
    return r;
  }
  // Rough: every heading at every candidate place.
  const std::vector<Eigen::Vector2d> cells = candidatePlaces(places, place_radius);
  const int yaws = static_cast<int>(std::lround(360.0 / kYawDeg[2]));
  std::vector<std::pair<double, Pose2>> rough(static_cast<std::size_t>(yaws) * cells.size());
  tbb::parallel_for(tbb::blocked_range<int>(0, yaws), [&](const auto& range) {
    for (int a = range.begin(); a < range.end(); ++a)
      for (std::size_t c = 0; c < cells.size(); ++c) {
        const Pose2 T{cells[c].x(), cells[c].y(), a * kYawDeg[2] * kDeg};
        rough[a * cells.size() + c] = {structureScore(q.thinner[2], target.structure(2), T), T};
      }
  });
  // Middle around the rough seeds, fine around the middle's best: the best refined is the answer.
  const std::vector<std::pair<double, Pose2>> seeds = bestDistinct(std::move(rough), kSeeds, kSeedDistinctMetres, kSeedDistinctDeg);
  std::vector<std::pair<double, Pose2>> middle(seeds.size()), refined;
  tbb::parallel_for(std::size_t(0), seeds.size(), [&](std::size_t i) { middle[i] = searchAround(q, target, 1, seeds[i].second); });
  for (const auto& m : bestDistinct(std::move(middle), kRefined, kDistinctMetres, kDistinctDeg))
    refined.push_back(searchAround(q, target, 0, m.second));
  std::stable_sort(refined.begin(), refined.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  return decide(q, refined, target.floorZ() - query_floor, r);
}

}  // namespace hazmap
