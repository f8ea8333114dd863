// Labels decide along an axis the geometry cannot observe (issue 19; the paper's point): in a
// corridor the walls fit as well a metre further along, but a heat panel or a puddle sits at one
// place. The scan's labelled points (raw, at kLabelAxisVoxel, isolated ones dropped) are slid
// along the axis (±label_axis.range) and scored against the labelled points of the verified
// frames placed at their poses: the kernel correlation of every labelled pair, their distance
// across the axis plus the paper's mismatch penalty α when the classes differ. A Gaussian of half
// kLabelAxisGate in steps of a tenth of the gate finds the peak, one of kLabelAxisVoxel in
// centimetres refines it. The position is decided only when kLabelAxisMinSupport labelled
// points agree there and no other peak kLabelAxisGate or more away scores kLabelAxisAmbiguity ×
// as much; it is precise when the two halves of the labelled points (alternate points) agree
// within kLabelAxisConsistency.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <unordered_set>
#include <vector>

#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/registration/registration_target.hpp"
#include "odometry/odometry_checks.hpp"

namespace hazmap {

namespace {

// A labelled scan point and a labelled map point close enough across the axis to agree at some
// offset along it: they coincide best at offset `at`; `across` = the squared distance left across
// the axis plus α when their classes differ.
struct LabelPair {
  float at;
  float across;
  float weight;  ///< the class weight, negative (× α) for a mismatch
  std::uint32_t source;
};

std::vector<LabelPair> labelPairs(const LabeledCloud& scan, const LabeledCloud& map, const ClassTable& classes,
                                  const Eigen::Isometry3d& pose, const Eigen::Vector3f& axis, float reach, float cut2) {
  const Eigen::Isometry3f T = pose.cast<float>();
  const auto alpha = static_cast<float>(classes.mismatch_penalty);
  std::vector<LabelPair> pairs;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const ClassId c = scan.classes[i];
    const bool labelled = classes.isProperty(c);
    const Eigen::Vector3f p = T * scan.points[i];
    const auto w = static_cast<float>(classes.at(c).weight);
    for (std::size_t j = 0; j < map.size(); ++j) {
      const bool same = map.classes[j] == c;
      if (same && !labelled) continue;  // unlabelled on unlabelled says nothing here
      const Eigen::Vector3f d = map.points[j] - p;
      const float at = axis.dot(d);
      if (std::abs(at) > reach) continue;
      const float across = d.squaredNorm() - at * at;
      // Same class: agreement. Else one side saw a label the other saw as something else: the
      // paper's mismatch penalty α (a partial view slid along a panel lands its unlabelled wall
      // on the map's panel).
      if (across <= cut2) pairs.push_back({at, across, same ? w : -alpha * w, static_cast<std::uint32_t>(i)});
    }
  }
  return pairs;
}

// Kernel correlation at `offset`: unlike the nearest partner, the sum over all partners peaks
// where two extended labelled regions (a 1.8 m puddle) overlap most, not anywhere the slid points
// still have a partner within the gate. `parity` 0/1 scores only even/odd scan points (-1: all).
double scoreAt(const std::vector<LabelPair>& pairs, float offset, float sigma, int parity = -1) {
  const float k = -0.5f / (sigma * sigma);
  double score = 0.0;
  for (const LabelPair& p : pairs) {
    if (parity >= 0 && static_cast<int>(p.source % 2) != parity) continue;
    const float along = offset - p.at;
    score += p.weight * std::exp(k * (p.across + along * along));
  }
  return score;
}

// Labelled scan points with a partner of their class at `offset` (kernel sum at least 0.5).
std::size_t supportAt(const std::vector<LabelPair>& pairs, float offset, float sigma) {
  const float k = -0.5f / (sigma * sigma);
  std::vector<std::pair<std::uint32_t, float>> sums;
  for (const LabelPair& p : pairs) {
    if (p.weight <= 0.0f) continue;
    const float along = offset - p.at;
    if (sums.empty() || sums.back().first != p.source) sums.push_back({p.source, 0.0f});
    sums.back().second += std::exp(k * (p.across + along * along));
  }
  return static_cast<std::size_t>(std::count_if(sums.begin(), sums.end(), [](const auto& s) { return s.second >= 0.5f; }));
}

// The best offset in centimetre steps within ±reach of `around`.
float refine(const std::vector<LabelPair>& pairs, float around, float reach, float sigma, int parity, double* top) {
  float best = around;
  double best_score = -1.0;
  for (float o = around - reach; o <= around + reach + 1e-4f; o += 0.01f)
    if (const double v = scoreAt(pairs, o, sigma, parity); v > best_score) best_score = v, best = o;
  if (top) *top = best_score;
  return best;
}

// The strongest other peak of the coarse profile: a local maximum at least `gate` from `best`,
// with a dip between the two.
double runnerUp(const std::vector<double>& score, int best, float step, float gate, double floor) {
  double second = floor;
  const int last = static_cast<int>(score.size()) - 1;
  for (int k = 0; k <= last; ++k) {
    if (std::abs(k - best) * step < gate || score[k] <= second) continue;
    const bool peak = (k == 0 || score[k] >= score[k - 1]) && (k == last || score[k] >= score[k + 1]);
    const auto [a, b] = std::minmax(k, best);
    const double dip = *std::min_element(score.begin() + a, score.begin() + b + 1);
    if (peak && dip - floor < 0.9 * (score[k] - floor)) second = score[k];
  }
  return second;
}

}  // namespace

LabeledCloud labelledPointsOf(const LabeledCloud& scan, const OdometryConfig& config, const ClassTable& classes) {
  std::vector<std::size_t> labelled, unlabelled;
  const auto r_min2 = static_cast<float>(config.min_range * config.min_range);
  const auto r_max2 = static_cast<float>(config.max_range * config.max_range);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const float r2 = scan.points[i].squaredNorm();
    if (!scan.points[i].allFinite() || r2 < r_min2 || r2 > r_max2) continue;
    if (classes.isProperty(scan.classes[i])) labelled.push_back(i);
    else if (!unobservedPoint(scan, i, false)) unlabelled.push_back(i);
  }
  // A label the sensor got wrong is a lone return; a heat panel or a puddle is a patch of them.
  // Kept: a labelled return with two more of its class within a few point spacings (2 cm per
  // metre of range: a VLP-16's 0.2 deg azimuth step is 0.35 cm per metre) — near the sensor the
  // radius stays small, or stray labels among thousands of returns would find company.
  std::vector<std::size_t> patch;
  for (const std::size_t i : labelled) {
    const Eigen::Vector3f& p = scan.points[i];
    const float radius = std::max(0.05f, 0.02f * p.norm());
    int company = 0;
    for (const std::size_t j : labelled)
      if (j != i && scan.classes[j] == scan.classes[i] && (scan.points[j] - p).squaredNorm() <= radius * radius &&
          ++company >= 2)
        break;
    if (company >= 2) patch.push_back(i);
  }
  VoxelDownsampleConfig vd;
  vd.voxel_size = kLabelAxisVoxel;
  LabeledCloud out = voxelDownsample(scan.select(patch), vd, classes);
  if (out.empty()) return out;
  // The unlabelled returns around the patches (cells of kLabelAxisContext next to one holding a
  // labelled point): where a panel ends, not where the view of it ends.
  const double cell = kLabelAxisContext;
  const auto key = [cell](const Eigen::Vector3f& p) {
    const auto q = [cell](float v) { return static_cast<std::int64_t>(std::floor(v / cell)) & 0x1fffff; };
    return (q(p.x()) << 42) | (q(p.y()) << 21) | q(p.z());
  };
  std::unordered_set<std::int64_t> near;
  for (std::size_t i = 0; i < out.size(); ++i)
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz)
          near.insert(key(out.points[i] + static_cast<float>(cell) * Eigen::Vector3f(dx, dy, dz)));
  std::vector<std::size_t> context;
  for (const std::size_t i : unlabelled)
    if (near.count(key(scan.points[i]))) context.push_back(i);
  out.append(voxelDownsample(scan.select(context), vd, classes));
  return out;
}

LabeledCloud labelMapOf(const std::vector<std::pair<Eigen::Isometry3d, const LabeledCloud*>>& frames,
                        const ClassTable& classes) {
  LabeledCloud all;
  for (const auto& [pose, labels] : frames) all.append(labels->transformed(pose));
  if (all.empty()) return all;
  // Labelled and unlabelled apart: a cell one frame saw labelled and another not keeps both.
  std::vector<std::size_t> labelled, unlabelled;
  for (std::size_t i = 0; i < all.size(); ++i) (classes.isProperty(all.classes[i]) ? labelled : unlabelled).push_back(i);
  VoxelDownsampleConfig vd;
  vd.voxel_size = kLabelAxisVoxel;
  LabeledCloud out = voxelDownsample(all.select(labelled), vd, classes);
  out.append(voxelDownsample(all.select(unlabelled), vd, classes));
  return out;
}

LabelPlacement placeAlongAxisByLabels(const LabelView& view, const ClassTable& classes, const Eigen::Isometry3d& pose,
                                      const Eigen::Vector3d& axis_d, const OdometryConfig& config) {
  LabelPlacement out;
  if (view.scan)
    out.labelled = static_cast<std::size_t>(std::count_if(view.scan->classes.begin(), view.scan->classes.end(),
                                                          [&](ClassId c) { return classes.isProperty(c); }));
  if (out.labelled == 0 || !view.map || view.map->empty()) {
    out.why = out.labelled == 0 ? "no labelled point in view" : "no labelled point in the map";
    return out;
  }
  const Eigen::Vector3f axis = axis_d.normalized().cast<float>();
  const auto gate = static_cast<float>(kLabelAxisGate);
  // The kernel: as wide as the labelled points' spacing (wider, the unlabelled returns next to a
  // panel's edge pay for its labelled points even at the right offset).
  const auto sigma = static_cast<float>(kLabelAxisVoxel), fine = sigma;
  const auto range = static_cast<float>(config.label_axis.range);
  const std::vector<LabelPair> pairs =
      labelPairs(*view.scan, *view.map, classes, pose, axis, range + 3.0f * sigma, 9.0f * sigma * sigma);
  char buf[220];
  const float step = sigma / 4.0f;
  const int n = static_cast<int>(std::floor(range / step));
  std::vector<double> score(2 * n + 1);
  for (int k = -n; k <= n; ++k) score[k + n] = scoreAt(pairs, k * step, sigma);
  const int best = static_cast<int>(std::max_element(score.begin(), score.end()) - score.begin());
  const float coarse = (best - n) * step;
  out.offset = refine(pairs, coarse, step, fine, -1, &out.score);
  out.support = supportAt(pairs, static_cast<float>(out.offset), fine);
  // Mismatches make scores negative: peaks are compared above the profile's floor.
  const double floor = *std::min_element(score.begin(), score.end());
  out.second = (std::max(runnerUp(score, best, step, gate, floor), floor) - floor) / std::max(score[best] - floor, 1e-9);
  out.decided = static_cast<double>(out.support) >= kLabelAxisMinSupport &&
                score[best] > floor && out.second <= kLabelAxisAmbiguity;
  if (!out.decided) {
    std::snprintf(buf, sizeof buf,
                  "labels undecided along the axis: %zu labelled points, %zu agree at %+.2f m, next peak %.0f %% of it",
                  out.labelled, out.support, out.offset, 100.0 * out.second);
    out.why = buf;
    return out;
  }
  // Precise: the two halves of the labelled points agree (far patches seen at a grazing angle
  // sample the axis every few decimetres).
  const float even = refine(pairs, static_cast<float>(out.offset), 2.0f * sigma, fine, 0, nullptr);
  const float odd = refine(pairs, static_cast<float>(out.offset), 2.0f * sigma, fine, 1, nullptr);
  out.spread = std::abs(even - odd);
  out.precise = out.spread <= kLabelAxisConsistency;
  return out;
}

std::string describe(const LabelPlacement& p) {
  char buf[220];
  std::snprintf(buf, sizeof buf,
                "labels placed it %+.2f m along the weak axis (%zu of %zu labelled points agree, next peak %.0f %%, halves %.2f m apart%s)",
                p.offset, p.support, p.labelled, 100.0 * p.second, p.spread, p.precise ? "" : ": imprecise, flagged");
  return p.decided ? std::string(buf) : p.why;
}

Eigen::Isometry3d shiftedAlong(const Eigen::Isometry3d& pose, const Eigen::Vector3d& axis, double offset) {
  Eigen::Isometry3d out = pose;
  out.translation() += offset * axis.normalized();
  return out;
}

}  // namespace hazmap
