#include "hazmap/map/hazard_changes.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <map>

#include "hazmap/io/atomic_file.hpp"

namespace hazmap {

namespace {

// Same hazard: same class, centroids within this (m; a VLP-16 sees a source's centroid to a few
// decimetres, and a map's voxels are 0.1 m).
constexpr double kSameHazard = 1.0;
// Moved: same class, unmatched on both sides, centroids within this (m).
constexpr double kMoveReach = 4.0;
// A matched hazard is reported moved when its centroid moved more than this (m) and its boxes
// before and after do not overlap or come within kFragmentMargin: within its old footprint a shifted
// centroid is the view (part of a puddle seen), not the hazard.
constexpr double kMovedTolerance = 0.5;
// An unmatched hazard within this (m) of a same-class hazard's box is a piece of it seen
// apart (a puddle seen in two parts from afar), not a new or gone one.
constexpr double kFragmentMargin = 0.5;
// Area change reported as grown/shrunk: by this factor and at least this much (m²). Shrunk only
// where the run's map holds at least as many cells in the old box as the hazard had: a hazard
// seen only in part from afar is not smaller.
constexpr double kAreaFactor = 1.5, kAreaMinChange = 0.25;
// max_property change reported (the property's unit, °C for heat).
constexpr double kValueChange = 10.0;
// Looked: at least this many cells of the run's map within the hazard's box grown by kLookMargin.
constexpr std::size_t kLookedCells = 20;
constexpr double kLookMargin = 0.3;
constexpr double kConfidentFrames = 10.0, kConfidentCells = 100.0;

std::size_t cellsIn(const LabeledCloud& map, const Hazard& h) {
  const Eigen::Vector3f lo = (h.min.array() - kLookMargin).cast<float>().matrix();
  const Eigen::Vector3f hi = (h.max.array() + kLookMargin).cast<float>().matrix();
  std::size_t n = 0;
  for (const auto& p : map.points) n += (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all();
  return n;
}

// The boxes overlap, or their gap is at most `margin` along every axis.
bool boxesOverlap(const Hazard& a, const Hazard& b, double margin) {
  return ((a.min.array() - margin) <= b.max.array()).all() && ((b.min.array() - margin) <= a.max.array()).all();
}

// An unmatched hazard that is a piece of a hazard of its class among `others` (those with
// `matched` set, when given: a piece of a matched hazard on its own side).
bool fragmentOf(const Hazard& h, const std::vector<Hazard>& others, const std::vector<bool>* matched = nullptr) {
  for (std::size_t k = 0; k < others.size(); ++k)
    if (&others[k] != &h && (!matched || (*matched)[k]) && others[k].label == h.label &&
        boxesOverlap(h, others[k], kFragmentMargin))
      return true;
  return false;
}

HazardChange pairOf(const Hazard* b, const Hazard* a) {
  HazardChange c;
  const Hazard& h = b ? *b : *a;
  c.class_name = h.class_name;
  if (b) {
    c.before_id = b->id, c.before = b->centroid, c.area_before_m2 = b->area_m2, c.value_before = b->max_property;
    c.frames_before = b->frames;
  }
  if (a) {
    c.after_id = a->id, c.after = a->centroid, c.area_after_m2 = a->area_m2, c.value_after = a->max_property;
    c.frames_after = a->frames;
    c.confidence = std::min(1.0, static_cast<double>(a->frame_count) / kConfidentFrames);
  }
  if (a && b) c.moved_m = (a->centroid - b->centroid).norm();
  return c;
}

// What differs between a hazard and its match (`seen_cells`: the run's map cells in the old box).
void classifyPair(HazardChange& c, const Hazard& before, const Hazard& after, std::size_t seen_cells) {
  if (c.moved_m > kMovedTolerance && !boxesOverlap(before, after, kFragmentMargin)) c.kinds.push_back("moved");
  const double da = c.area_after_m2 - c.area_before_m2;
  if (da >= kAreaMinChange && c.area_after_m2 > kAreaFactor * c.area_before_m2) c.kinds.push_back("grown");
  if (-da >= kAreaMinChange && c.area_before_m2 > kAreaFactor * c.area_after_m2 && seen_cells >= before.cells)
    c.kinds.push_back("shrunk");
  if (c.value_before && c.value_after && std::abs(*c.value_after - *c.value_before) >= kValueChange)
    c.kinds.push_back("value_changed");
  if (c.kinds.empty()) c.kinds.push_back("unchanged");
}

// Greedy matching of same-class hazards, nearest pairs first, within `reach`.
void matchWithin(const std::vector<Hazard>& before, const std::vector<Hazard>& after, double reach,
                 std::vector<int>& match_of_before, std::vector<bool>& after_used) {
  std::vector<std::tuple<double, std::size_t, std::size_t>> pairs;
  for (std::size_t i = 0; i < before.size(); ++i)
    for (std::size_t j = 0; j < after.size(); ++j)
      if (match_of_before[i] < 0 && !after_used[j] && before[i].label == after[j].label) {
        const double d = (before[i].centroid - after[j].centroid).norm();
        if (d <= reach) pairs.emplace_back(d, i, j);
      }
  std::sort(pairs.begin(), pairs.end());
  for (const auto& [d, i, j] : pairs)
    if (match_of_before[i] < 0 && !after_used[j]) match_of_before[i] = static_cast<int>(j), after_used[j] = true;
}

}  // namespace

bool HazardChange::changed() const {
  return !(kinds.size() == 1 && (kinds[0] == "unchanged" || kinds[0] == "not_re_observed" || kinds[0] == "part_of"));
}

std::vector<HazardChange> compareHazards(const std::vector<Hazard>& before, const std::vector<Hazard>& after,
                                         const LabeledCloud& after_map) {
  std::vector<int> match(before.size(), -1);
  std::vector<bool> used(after.size(), false);
  matchWithin(before, after, kSameHazard, match, used);
  matchWithin(before, after, kMoveReach, match, used);
  std::vector<bool> before_matched(before.size());
  for (std::size_t i = 0; i < before.size(); ++i) before_matched[i] = match[i] >= 0;
  std::vector<HazardChange> out;
  for (std::size_t i = 0; i < before.size(); ++i) {
    const std::size_t cells = cellsIn(after_map, before[i]);
    if (match[i] >= 0) {
      const Hazard& a = after[static_cast<std::size_t>(match[i])];
      out.push_back(pairOf(&before[i], &a));
      classifyPair(out.back(), before[i], a, cells);
      continue;
    }
    HazardChange c = pairOf(&before[i], nullptr);
    c.kinds.push_back(fragmentOf(before[i], before, &before_matched) ? "part_of"
                      : cells < kLookedCells                           ? "not_re_observed"
                      : fragmentOf(before[i], after)                   ? "unchanged"
                                                                       : "gone");
    c.confidence = std::min(1.0, static_cast<double>(cells) / kConfidentCells);
    out.push_back(std::move(c));
  }
  for (std::size_t j = 0; j < after.size(); ++j)
    if (!used[j]) {
      out.push_back(pairOf(nullptr, &after[j]));
      out.back().kinds.push_back(fragmentOf(after[j], after, &used) ? "part_of"
                                 : fragmentOf(after[j], before)      ? "unchanged"
                                                                     : "new");
    }
  return out;
}

}  // namespace hazmap
