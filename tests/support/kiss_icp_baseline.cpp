#include "kiss_icp_baseline.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>

#include "hazmap/core/se3.hpp"

namespace hazmap::baseline {
namespace {

using Vec3 = Eigen::Vector3d;
using Points = std::vector<Vec3>;

struct Key {
  std::int64_t x, y, z;
  bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct KeyHash {  // the usual spatial hash (Teschner et al. 2003)
  std::size_t operator()(const Key& k) const {
    return static_cast<std::size_t>((k.x * 73856093) ^ (k.y * 19349669) ^ (k.z * 83492791));
  }
};
Key keyOf(const Vec3& p, double voxel) {
  return {static_cast<std::int64_t>(std::floor(p.x() / voxel)), static_cast<std::int64_t>(std::floor(p.y() / voxel)),
          static_cast<std::int64_t>(std::floor(p.z() / voxel))};
}

// One point per voxel, the first one seen, in first-seen order.
Points voxelize(const Points& in, double voxel) {
  std::unordered_map<Key, std::size_t, KeyHash> seen;
  seen.reserve(in.size());
  Points out;
  for (const Vec3& p : in)
    if (seen.emplace(keyOf(p, voxel), out.size()).second) out.push_back(p);
  return out;
}

struct Normal {  // the normal equations of one ICP step, summed over correspondences
  Matrix6d JTJ = Matrix6d::Zero();
  Vector6d JTr = Vector6d::Zero();
  void add(const Normal& o) {
    JTJ += o.JTJ;
    JTr += o.JTr;
  }
};

}  // namespace

struct KissIcp::Map {
  double voxel;
  int max_points;
  std::unordered_map<Key, Points, KeyHash> voxels;

  // The nearest map point within the 27 voxels around p; infinity when none.
  double nearest(const Vec3& p, Vec3& q) const {
    const Key k = keyOf(p, voxel);
    double best = std::numeric_limits<double>::infinity();
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = voxels.find({k.x + dx, k.y + dy, k.z + dz});
          if (it == voxels.end()) continue;
          for (const Vec3& m : it->second)
            if (const double d = (m - p).squaredNorm(); d < best) best = d, q = m;
        }
    return best;
  }
  void add(const Points& world, const Vec3& origin, double max_range) {
    for (const Vec3& p : world) {
      Points& v = voxels[keyOf(p, voxel)];
      if (static_cast<int>(v.size()) < max_points) v.push_back(p);
    }
    for (auto it = voxels.begin(); it != voxels.end();)
      it = (it->second.front() - origin).norm() > max_range ? voxels.erase(it) : std::next(it);
  }
};

KissIcp::KissIcp(const KissIcpConfig& config) : config_(config), map_(std::make_unique<Map>(Map{config.voxel_size, config.max_points_per_voxel, {}})) {}
KissIcp::~KissIcp() = default;

// σ: the RMS of the motion model's deviations so far that exceeded min_motion_threshold
// (translation plus the rotation's displacement at max_range), the initial threshold before any.
double KissIcp::threshold() const {
  return model_samples_ < 1 ? config_.initial_threshold : std::sqrt(model_sse_ / model_samples_);
}

namespace {

// Point-to-point ICP with the Geman–McClure kernel, from `guess` (map ← source).
Eigen::Isometry3d icp(const Points& source, const KissIcp::Map& map, Eigen::Isometry3d T, double gate, double kernel,
                      const KissIcpConfig& config) {
  const double gate2 = gate * gate;
  for (int it = 0; it < config.max_iterations; ++it) {
    const Normal n = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, source.size()), Normal{},
        [&](const tbb::blocked_range<std::size_t>& r, Normal acc) {
          for (std::size_t i = r.begin(); i != r.end(); ++i) {
            const Vec3 p = T * source[i];
            Vec3 q;
            if (map.nearest(p, q) > gate2) continue;
            const Vec3 res = p - q;
            Eigen::Matrix<double, 3, 6> J;
            J.leftCols<3>().setIdentity();
            J.rightCols<3>() = -hat(p);
            const double w = kernel * kernel / std::pow(kernel + res.squaredNorm(), 2);
            acc.JTJ += w * J.transpose() * J;
            acc.JTr += w * J.transpose() * res;
          }
          return acc;
        },
        [](Normal a, const Normal& b) {
          a.add(b);
          return a;
        });
    const Vector6d dx = n.JTJ.ldlt().solve(-n.JTr);
    if (!dx.allFinite()) break;
    T = se3Exp(dx) * T;
    if (dx.norm() < config.convergence) break;
  }
  return T;
}

}  // namespace

Eigen::Isometry3d KissIcp::addFrame(const LabeledCloud& scan) {
  Points frame;
  frame.reserve(scan.size());
  for (const Eigen::Vector3f& p : scan.points) {
    const Vec3 d = p.cast<double>();
    const double r = d.norm();
    if (d.allFinite() && r < config_.max_range && r > config_.min_range) frame.push_back(d);
  }
  const Points downsampled = voxelize(frame, 0.5 * config_.voxel_size);
  const Points source = voxelize(downsampled, 1.5 * config_.voxel_size);
  const Eigen::Isometry3d last = poses_.empty() ? Eigen::Isometry3d::Identity() : poses_.back();
  const Eigen::Isometry3d guess = last * last_delta_;
  last_sigma_ = threshold();
  const Eigen::Isometry3d pose = map_->voxels.empty()
      ? guess : normalized(icp(source, *map_, guess, 3.0 * last_sigma_, last_sigma_ / 3.0, config_));
  const Eigen::Isometry3d deviation = guess.inverse() * pose;
  const double model_error = translationNorm(deviation) + 2.0 * config_.max_range * std::sin(rotationAngle(deviation) / 2.0);
  if (model_error > config_.min_motion_threshold) {
    model_sse_ += model_error * model_error;
    ++model_samples_;
  }
  last_delta_ = last.inverse() * pose;
  Points world;
  world.reserve(downsampled.size());
  for (const Vec3& p : downsampled) world.push_back(pose * p);
  map_->add(world, pose.translation(), config_.max_range);
  poses_.push_back(pose);
  return pose;
}

}  // namespace hazmap::baseline
