#include "hazmap/sim/odometry_noise.hpp"

#include <cmath>

#include "hazmap/core/se3.hpp"

namespace hazmap::sim {

Eigen::Isometry3d PlanarIncrement::toPose() const { return fromXyYaw(forward, lateral, yaw); }

PlanarIncrement PlanarIncrement::between(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b) {
  const Eigen::Isometry3d rel = T_a.inverse() * T_b;
  return {rel.translation().x(), rel.translation().y(), yawOf(rel)};
}

PlanarIncrement noisyIncrement(const PlanarIncrement& truth, const OdometryNoiseConfig& c, Rng& rng,
                               bool* slipped) {
  constexpr double kDeg = M_PI / 180.0;
  // Fixed draw order, all draws always made, so one frame's noise never shifts another's.
  const double scale = rng.normal(c.forward_scale_sigma);
  const double lateral = rng.normal(c.lateral_sigma);
  const double yaw_noise = rng.normal(c.yaw_sigma_deg * kDeg);
  const double skid = rng.normal(c.skid_fraction * std::abs(truth.yaw));
  const bool slip = rng.bernoulli(c.slip_probability);
  const double slip_extra = rng.uniform(c.slip_min, c.slip_max);
  PlanarIncrement out;
  out.forward = truth.forward * (1.0 + scale) + (slip ? slip_extra : 0.0);
  out.lateral = truth.lateral + lateral;
  out.yaw = truth.yaw + yaw_noise + skid;
  if (slipped) *slipped = slip;
  return out;
}

std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> accumulateOdometry(
    const std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>& truth,
    const OdometryNoiseConfig& config, std::uint64_t seed, std::vector<bool>* slipped,
    const std::vector<double>* unseen_yaw) {
  std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> odo;
  if (slipped) slipped->assign(truth.size(), false);
  if (truth.empty()) return odo;
  odo.reserve(truth.size());
  odo.push_back(truth.front());
  for (std::size_t i = 1; i < truth.size(); ++i) {
    Rng rng(seed, RngStream::Odometry, i);
    bool slip = false;
    PlanarIncrement seen = PlanarIncrement::between(truth[i - 1], truth[i]);
    if (unseen_yaw && i < unseen_yaw->size()) seen.yaw -= (*unseen_yaw)[i];
    const PlanarIncrement measured = noisyIncrement(seen, config, rng, &slip);
    if (slipped) (*slipped)[i] = slip;
    odo.push_back(normalized(odo.back() * measured.toPose()));
  }
  return odo;
}

std::vector<double> applyCrawlerUpsets(std::vector<RouteSample>& samples, const CrawlerUpsetConfig& c,
                                       std::uint64_t seed) {
  constexpr double kDeg = M_PI / 180.0;
  std::vector<RouteSample> kept;
  std::vector<double> kicks;
  kept.reserve(samples.size());
  double heading_offset = 0.0;
  bool dropped_last = false;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    // Fixed draw order, all draws always made (as noisyIncrement).
    Rng rng(seed, RngStream::Upset, i);
    const bool drop = rng.bernoulli(c.drop_probability);
    const bool kick = rng.bernoulli(c.yaw_kick_probability);
    const double size = rng.uniform(c.yaw_kick_min_deg, c.yaw_kick_max_deg) * kDeg;
    const double sign = rng.bernoulli(0.5) ? 1.0 : -1.0;
    if (i > 0 && drop && !dropped_last && i + 1 < samples.size()) {
      dropped_last = true;
      continue;
    }
    dropped_last = false;
    const double k = (i > 0 && kick) ? sign * size : 0.0;
    heading_offset += k;
    RouteSample s = samples[i];
    s.yaw = std::remainder(s.yaw + heading_offset, 2.0 * M_PI);
    kept.push_back(s);
    kicks.push_back(k);
  }
  samples = std::move(kept);
  return kicks;
}

}  // namespace hazmap::sim
