// Labels decide along an axis the geometry cannot observe (issue 19; the paper's point): in a
// corridor the walls fit as well a metre further along, but a heat panel or a puddle sits at one
// place. The scan's labelled points are slid along the axis (±label_axis_range) and scored
// against the target's labelled points: the kernel correlation (a Gaussian of half
// label_axis_gate) of every labelled pair, their distance across the axis plus the paper's
// mismatch penalty α when the classes differ. Coarse steps of a tenth of the gate, then
// centimetres; the position is decided only when label_axis_min_support labelled points agree
// there and no other peak label_axis_gate or more away scores label_axis_ambiguity × as much.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <string>
#include <vector>

#include "odometry/odometry_checks.hpp"

namespace hazmap {

namespace {

// A labelled source point and a labelled target point close enough across the axis to agree at
// some offset along it: they coincide best at offset `at`, `across` = the squared distance left
// across the axis plus α when their classes differ.
struct LabelPair {
  float at;
  float across;
  float weight;
  std::uint32_t source;
};

std::vector<LabelPair> labelPairs(const LabeledCloud& source, const RegistrationTarget& target,
                                  const ClassTable& classes, const Eigen::Isometry3d& pose, const Eigen::Vector3f& axis,
                                  float reach, float cut2, std::size_t& labelled) {
  const Eigen::Isometry3f T = pose.cast<float>();
  const LabeledCloud& map = target.cloud();
  std::vector<std::size_t> map_labelled;
  const Eigen::Vector3f centre = T.translation();
  const float far2 = (reach + 100.0f) * (reach + 100.0f);  // beyond any scan's range
  for (std::size_t j = 0; j < map.size(); ++j)
    if (classes.isProperty(map.classes[j]) && (map.points[j] - centre).squaredNorm() < far2) map_labelled.push_back(j);
  const float alpha = target.usesClasses() ? target.penalty() : 0.0f;
  std::vector<LabelPair> pairs;
  labelled = 0;
  for (std::size_t i = 0; i < source.size(); ++i) {
    const ClassId c = source.classes[i];
    if (!classes.isProperty(c)) continue;
    const Eigen::Vector3f p = T * source.points[i];
    if (!p.allFinite()) continue;
    ++labelled;
    const auto w = static_cast<float>(classes.at(c).weight);
    for (const std::size_t j : map_labelled) {
      const Eigen::Vector3f d = map.points[j] - p;
      const float at = axis.dot(d);
      if (std::abs(at) > reach) continue;
      const float across = d.squaredNorm() - at * at + (map.classes[j] == c ? 0.0f : alpha);
      if (across <= cut2) pairs.push_back({at, across, w, static_cast<std::uint32_t>(i)});
    }
  }
  return pairs;
}

// Kernel correlation of the labelled points at `offset` (a Gaussian of width sigma): unlike the
// nearest partner, the sum over all partners peaks where two extended labelled regions (a 1.8 m
// puddle) overlap most, not anywhere the slid points still have a partner within the gate.
double scoreAt(const std::vector<LabelPair>& pairs, float offset, float sigma) {
  const float k = -0.5f / (sigma * sigma);
  double score = 0.0;
  for (const LabelPair& p : pairs) {
    const float along = offset - p.at;
    score += p.weight * std::exp(k * (p.across + along * along));
  }
  return score;
}

// Labelled source points with a partner at `offset` (kernel sum >= 0.5).
std::size_t supportAt(const std::vector<LabelPair>& pairs, float offset, float sigma) {
  const float k = -0.5f / (sigma * sigma);
  std::vector<std::pair<std::uint32_t, float>> sums;
  for (const LabelPair& p : pairs) {
    const float along = offset - p.at;
    const float v = std::exp(k * (p.across + along * along));
    if (sums.empty() || sums.back().first != p.source) sums.push_back({p.source, 0.0f});
    sums.back().second += v;
  }
  return static_cast<std::size_t>(std::count_if(sums.begin(), sums.end(), [](const auto& s) { return s.second >= 0.5f; }));
}

}  // namespace

LabelPlacement placeAlongAxisByLabels(const LabeledCloud& source, const RegistrationTarget& target,
                                      const ClassTable& classes, const Eigen::Isometry3d& pose,
                                      const Eigen::Vector3d& axis_d, const OdometryConfig& config) {
  LabelPlacement out;
  const Eigen::Vector3f axis = axis_d.normalized().cast<float>();
  const float gate = static_cast<float>(config.label_axis_gate), sigma = gate / 2.0f;
  const float range = static_cast<float>(config.label_axis_range);
  const std::vector<LabelPair> pairs =
      labelPairs(source, target, classes, pose, axis, range + gate, gate * gate, out.labelled);
  char buf[200];
  if (pairs.empty()) {
    std::snprintf(buf, sizeof buf, "labels undecided along the axis: %zu labelled points, none with a labelled partner",
                  out.labelled);
    out.why = out.labelled == 0 ? std::string("no labelled point in view") : std::string(buf);
    return out;
  }
  const float step = sigma / 5.0f;
  const int n = static_cast<int>(std::floor(range / step));
  std::vector<double> score(2 * n + 1);
  for (int k = -n; k <= n; ++k) score[k + n] = scoreAt(pairs, k * step, sigma);
  const int best = static_cast<int>(std::max_element(score.begin(), score.end()) - score.begin());
  // Refined in centimetre steps around the best coarse step.
  float offset = (best - n) * step;
  double top = score[best];
  for (float o = offset - step; o <= offset + step + 1e-4f; o += 0.01f)
    if (const double v = scoreAt(pairs, o, sigma); v > top) top = v, offset = o;
  out.offset = offset;
  out.score = top;
  out.support = supportAt(pairs, offset, sigma);
  // The runner-up is another peak: a local maximum beyond the gate, with a dip between the two.
  for (int k = 0; k <= 2 * n; ++k) {
    if (std::abs(k - best) * step < gate || score[k] <= out.second) continue;
    const bool peak = (k == 0 || score[k] >= score[k - 1]) && (k == 2 * n || score[k] >= score[k + 1]);
    const auto [a, b] = std::minmax(k, best);
    const double dip = *std::min_element(score.begin() + a, score.begin() + b + 1);
    if (peak && dip < 0.9 * score[k]) out.second = score[k];
  }
  out.decided = static_cast<double>(out.support) >= config.label_axis_min_support &&
                out.second <= config.label_axis_ambiguity * out.score;
  if (!out.decided) {
    std::snprintf(buf, sizeof buf,
                  "labels undecided along the axis: %zu labelled points, %zu agree at %+.2f m (score %.1f), next peak %.1f",
                  out.labelled, out.support, out.offset, out.score, out.second);
    out.why = buf;
  }
  return out;
}

std::string describe(const LabelPlacement& p) {
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "labels placed it %+.2f m along the weak axis (%zu of %zu labelled points agree; score %.1f, next peak %.1f)",
                p.offset, p.support, p.labelled, p.score, p.second);
  return p.decided ? std::string(buf) : p.why;
}

Eigen::Isometry3d shiftedAlong(const Eigen::Isometry3d& pose, const Eigen::Vector3d& axis, double offset) {
  Eigen::Isometry3d out = pose;
  out.translation() += offset * axis.normalized();
  return out;
}

}  // namespace hazmap
