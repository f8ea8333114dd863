#include "hazmap/eval/trajectory_metrics.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numeric>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"

namespace hazmap {

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

using PoseVector = std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>;

// Angle of a rotation matrix from its trace, clamped like evo / the KITTI devkit.
double angleOf(const Eigen::Matrix3d& R) {
  const double c = std::clamp(0.5 * (R.trace() - 1.0), -1.0, 1.0);
  return std::acos(c);
}

// The devkit's rotationError / translationError, in its single precision.
float devkitRotationError(const Eigen::Matrix4d& e) {
  const float a = static_cast<float>(e(0, 0)), b = static_cast<float>(e(1, 1)), c = static_cast<float>(e(2, 2));
  const float d = static_cast<float>(0.5 * (a + b + c - 1.0));
  return std::acos(std::max(std::min(d, 1.0f), -1.0f));
}
float devkitTranslationError(const Eigen::Matrix4d& e) {
  const float dx = static_cast<float>(e(0, 3)), dy = static_cast<float>(e(1, 3)), dz = static_cast<float>(e(2, 3));
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

void checkPair(const Trajectory& gt, const Trajectory& est, const std::string& where) {
  checkTrajectory(gt, where + ": ground truth");
  checkTrajectory(est, where + ": estimate");
  if (gt.size() != est.size())
    fail(where, "ground truth has " + std::to_string(gt.size()) + " poses but the estimate has " +
                    std::to_string(est.size()) + " (associate them first)");
}

PoseVector applyTransform(const SimilarityTransform& S, const PoseVector& poses) {
  PoseVector out;
  out.reserve(poses.size());
  for (const auto& P : poses) {
    Eigen::Isometry3d Q = Eigen::Isometry3d::Identity();
    Q.linear() = S.rotation * P.linear();
    Q.translation() = S.apply(P.translation());
    out.push_back(Q);
  }
  return out;
}

SimilarityTransform alignmentFor(const Trajectory& gt, const Trajectory& est, Alignment alignment) {
  if (alignment == Alignment::None) return {};
  std::vector<Eigen::Vector3d> x, y;
  x.reserve(est.size());
  y.reserve(gt.size());
  for (std::size_t i = 0; i < est.size(); ++i) {
    x.push_back(est.poses[i].translation());
    y.push_back(gt.poses[i].translation());
  }
  return umeyamaAlignment(x, y, alignment == Alignment::Sim3);
}

}  // namespace

const char* toString(Alignment alignment) {
  switch (alignment) {
    case Alignment::None: return "none";
    case Alignment::SE3: return "se3";
    case Alignment::Sim3: return "sim3";
  }
  return "?";
}

std::optional<Alignment> parseAlignment(const std::string& text) {
  if (text == "none") return Alignment::None;
  if (text == "se3") return Alignment::SE3;
  if (text == "sim3") return Alignment::Sim3;
  return std::nullopt;
}

ErrorStats summarize(const std::vector<double>& errors, const std::string& where) {
  if (errors.empty()) fail(where, "no errors to summarise");
  ErrorStats s;
  s.count = errors.size();
  const double n = static_cast<double>(errors.size());
  double sum = 0, sum_sq = 0;
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double var = 0;
  for (double e : errors) var += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(var / n);
  std::vector<double> sorted = errors;
  std::sort(sorted.begin(), sorted.end());
  s.min = sorted.front();
  s.max = sorted.back();
  const std::size_t mid = sorted.size() / 2;
  s.median = sorted.size() % 2 ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
  return s;
}

SimilarityTransform umeyamaAlignment(const std::vector<Eigen::Vector3d>& source,
                                     const std::vector<Eigen::Vector3d>& target, bool with_scale) {
  if (source.size() != target.size())
    fail("umeyama alignment", "point counts differ (" + std::to_string(source.size()) + " vs " +
                                  std::to_string(target.size()) + ")");
  if (source.size() < 3) fail("umeyama alignment", "needs at least 3 positions");
  const double n = static_cast<double>(source.size());
  Eigen::Vector3d mean_x = Eigen::Vector3d::Zero(), mean_y = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < source.size(); ++i) {
    mean_x += source[i];
    mean_y += target[i];
  }
  mean_x /= n;
  mean_y /= n;
  double sigma_x = 0;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < source.size(); ++i) {
    const Eigen::Vector3d dx = source[i] - mean_x;
    sigma_x += dx.squaredNorm();
    cov += (target[i] - mean_y) * dx.transpose();
  }
  sigma_x /= n;
  cov /= n;
  if (!(sigma_x > 0)) fail("umeyama alignment", "all estimate positions are equal");
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d d = svd.singularValues();
  // Umeyama needs rank >= m - 1 (a straight line has no defined rotation about itself).
  const int rank = static_cast<int>((d.array() > std::numeric_limits<double>::epsilon()).count());
  if (rank < 2)
    fail("umeyama alignment", "degenerate positions (collinear or identical): cannot align");
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) S(2, 2) = -1;
  SimilarityTransform T;
  T.rotation = svd.matrixU() * S * svd.matrixV().transpose();
  T.scale = with_scale ? (d.asDiagonal() * S).trace() / sigma_x : 1.0;
  T.translation = mean_y - T.scale * T.rotation * mean_x;
  return T;
}

void checkTrajectory(const Trajectory& trajectory, const std::string& where) {
  if (trajectory.empty()) fail(where, "trajectory is empty");
  if (trajectory.stamps.size() != trajectory.poses.size())
    fail(where, "time stamps and poses differ in count");
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    if (!isFinite(trajectory.poses[i]))
      fail(where, "pose " + std::to_string(i) + " is not finite (NaN or Inf)");
    if (!std::isfinite(trajectory.stamps[i]))
      fail(where, "time stamp " + std::to_string(i) + " is not finite");
  }
}

std::pair<Trajectory, Trajectory> associateTrajectories(const Trajectory& gt, const Trajectory& est,
                                                        double max_dt) {
  checkTrajectory(gt, "associate: ground truth");
  checkTrajectory(est, "associate: estimate");
  const bool est_longer = est.size() > gt.size();
  const Trajectory& shorter = est_longer ? gt : est;
  const Trajectory& longer = est_longer ? est : gt;
  // Sorted view of the longer trajectory's stamps for a binary search; ties resolve to the
  // lowest index, as numpy's argmin over the unsorted stamps does for sorted input.
  std::vector<std::size_t> order(longer.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return longer.stamps[a] < longer.stamps[b]; });
  Trajectory out_short, out_long;
  for (std::size_t i = 0; i < shorter.size(); ++i) {
    const double t = shorter.stamps[i];
    auto it = std::lower_bound(order.begin(), order.end(), t,
                               [&](std::size_t k, double v) { return longer.stamps[k] < v; });
    std::size_t best = order.size();
    double best_dt = std::numeric_limits<double>::infinity();
    for (auto c : {it == order.begin() ? order.end() : it - 1, it}) {
      if (c == order.end()) continue;
      const double dt = std::abs(longer.stamps[*c] - t);
      if (dt < best_dt || (dt == best_dt && *c < best)) {
        best_dt = dt;
        best = *c;
      }
    }
    if (best < order.size() && best_dt <= max_dt) {
      out_short.push_back(shorter.stamps[i], shorter.poses[i]);
      out_long.push_back(longer.stamps[best], longer.poses[best]);
    }
  }
  if (out_short.empty())
    fail("associate", "no time stamps of the two trajectories match within " +
                          std::to_string(max_dt) + " s");
  if (est_longer) return {std::move(out_short), std::move(out_long)};
  return {std::move(out_long), std::move(out_short)};
}

ApeResult computeApe(const Trajectory& gt, const Trajectory& est, Alignment alignment) {
  checkPair(gt, est, "ape");
  ApeResult r;
  r.alignment = alignment;
  r.transform = alignmentFor(gt, est, alignment);
  const PoseVector aligned = applyTransform(r.transform, est.poses);
  std::vector<double> rot(gt.size());
  r.errors.resize(gt.size());
  for (std::size_t i = 0; i < gt.size(); ++i) {
    r.errors[i] = (gt.poses[i].translation() - aligned[i].translation()).norm();
    rot[i] = angleOf(gt.poses[i].linear().transpose() * aligned[i].linear()) * kRadToDeg;
  }
  r.translation = summarize(r.errors, "ape");
  r.rotation_deg = summarize(rot, "ape");
  return r;
}

std::vector<std::pair<std::size_t, std::size_t>> rpePairsByPath(const PoseVector& poses, double delta) {
  std::vector<std::size_t> ids;
  if (poses.empty()) return {};
  double path = 0.0;
  Eigen::Vector3d previous = poses.front().translation();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Vector3d current = poses[i].translation();
    path += (current - previous).norm();
    previous = current;
    if (path >= delta) {
      ids.push_back(i);
      path = 0.0;
    }
  }
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t k = 0; k + 1 < ids.size(); ++k) pairs.emplace_back(ids[k], ids[k + 1]);
  return pairs;
}

std::vector<std::pair<std::size_t, std::size_t>> rpePairsByFrames(std::size_t count, std::size_t delta) {
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  if (delta == 0) return pairs;
  for (std::size_t i = 0; i + delta < count; i += delta) pairs.emplace_back(i, i + delta);
  return pairs;
}

RpeResult computeRpe(const Trajectory& gt, const Trajectory& est, const RpeConfig& config) {
  checkPair(gt, est, "rpe");
  if (!(config.delta > 0) || !std::isfinite(config.delta))
    fail("rpe", "delta must be a positive number (got " + std::to_string(config.delta) + ")");
  RpeResult r;
  r.config = config;
  const PoseVector P = applyTransform(alignmentFor(gt, est, config.alignment), est.poses);
  const PoseVector& Q = gt.poses;
  if (config.unit == DeltaUnit::Metres) {
    r.pairs = rpePairsByPath(P, config.delta);
  } else {
    if (config.delta != std::floor(config.delta))
      fail("rpe", "a delta in frames must be a whole number");
    r.pairs = rpePairsByFrames(P.size(), static_cast<std::size_t>(config.delta));
  }
  if (r.pairs.empty())
    fail("rpe", "no pose pair is " + std::to_string(config.delta) +
                    (config.unit == DeltaUnit::Metres ? " m" : " frames") +
                    " apart (trajectory too short for this delta)");
  std::vector<double> rot;
  rot.reserve(r.pairs.size());
  r.errors.reserve(r.pairs.size());
  for (const auto& [i, j] : r.pairs) {
    const Eigen::Isometry3d E = (Q[i].inverse() * Q[j]).inverse() * (P[i].inverse() * P[j]);
    r.errors.push_back(E.translation().norm());
    rot.push_back(angleOf(E.linear()) * kRadToDeg);
  }
  r.translation = summarize(r.errors, "rpe");
  r.rotation_deg = summarize(rot, "rpe");
  return r;
}

KittiResult computeKittiErrors(const Trajectory& gt, const Trajectory& est, const KittiConfig& config) {
  checkPair(gt, est, "kitti");
  if (config.step_size == 0) fail("kitti", "step_size must be >= 1");
  for (double len : config.lengths)
    if (!(len > 0)) fail("kitti", "segment lengths must be positive");
  // As the devkit (evaluate_odometry.cpp) computes it, operation for operation: the file's
  // matrices as given with general 4×4 inverses (no re-orthonormalisation), then single
  // precision for path distances, segment lengths, per-segment errors (acos of a float) and their
  // sums — so t_err and r_err agree with the devkit's own output, float rounding included.
  const auto& Q = gt.poses;
  const auto& P = est.poses;
  std::vector<float> dist(Q.size(), 0.0f);
  for (std::size_t i = 1; i < Q.size(); ++i) {
    const Eigen::Vector3d d = Q[i - 1].matrix().topRightCorner<3, 1>() - Q[i].matrix().topRightCorner<3, 1>();
    const float dx = static_cast<float>(d.x()), dy = static_cast<float>(d.y()), dz = static_cast<float>(d.z());
    dist[i] = dist[i - 1] + std::sqrt(dx * dx + dy * dy + dz * dz);
  }
  KittiResult r;
  std::vector<float> t_sum(config.lengths.size(), 0.0f), r_sum(config.lengths.size(), 0.0f);
  std::vector<std::size_t> n(config.lengths.size(), 0);
  float t_total = 0, r_total = 0;
  for (std::size_t first = 0; first < Q.size(); first += config.step_size) {
    for (std::size_t l = 0; l < config.lengths.size(); ++l) {
      const float len = static_cast<float>(config.lengths[l]);
      // lastFrameFromSegmentLength: the first frame whose distance exceeds dist[first] + len
      const auto it = std::upper_bound(dist.begin() + first, dist.end(), dist[first] + len);
      if (it == dist.end()) continue;
      const std::size_t last = static_cast<std::size_t>(it - dist.begin());
      const Eigen::Matrix4d dq = Q[first].matrix().inverse() * Q[last].matrix();
      const Eigen::Matrix4d dp = P[first].matrix().inverse() * P[last].matrix();
      const Eigen::Matrix4d err = dp.inverse() * dq;
      const float t_err = devkitTranslationError(err) / len;
      const float r_err = devkitRotationError(err) / len;
      t_sum[l] += t_err;
      r_sum[l] += r_err;
      ++n[l];
      t_total += t_err;
      r_total += r_err;
      ++r.segments;
    }
  }
  const auto average = [](float sum, std::size_t count) { return double(sum / static_cast<float>(count)); };
  if (r.segments > 0) {
    r.t_err_pct = 100.0 * average(t_total, r.segments);
    r.r_err_deg_per_100m = 100.0 * kRadToDeg * average(r_total, r.segments);
  }
  for (std::size_t l = 0; l < config.lengths.size(); ++l) {
    if (n[l] == 0) continue;
    KittiLengthError e;
    e.length = config.lengths[l];
    e.segments = n[l];
    e.t_err_pct = 100.0 * average(t_sum[l], n[l]);
    e.r_err_deg_per_100m = 100.0 * kRadToDeg * average(r_sum[l], n[l]);
    r.per_length.push_back(e);
  }
  return r;
}

double pathLength(const Trajectory& trajectory) {
  double len = 0;
  for (std::size_t i = 1; i < trajectory.size(); ++i)
    len += (trajectory.poses[i].translation() - trajectory.poses[i - 1].translation()).norm();
  return len;
}

namespace {
TrajectoryEvaluation evaluateRelative(const Trajectory& gt, const Trajectory& est,
                                      const TrajectoryEvalConfig& config, TrajectoryEvaluation e);
}  // namespace

TrajectoryEvaluation evaluateTrajectory(const Trajectory& gt, const Trajectory& est,
                                        const TrajectoryEvalConfig& config) {
  TrajectoryEvaluation e;
  e.ape = computeApe(gt, est, config.ape_alignment);  // validates both trajectories
  e.poses = gt.size();
  e.gt_length_m = pathLength(gt);
  e.est_length_m = pathLength(est);
  // Sim(3): the scale found by the alignment applies to RPE and the KITTI segments too, as in
  // evo's --correct_scale and kitti-odom-eval's --align 7dof (a monocular estimate has no scale
  // of its own). The rigid part changes no relative pose.
  Trajectory scaled;
  if (config.ape_alignment == Alignment::Sim3) {
    scaled.stamps = est.stamps;
    scaled.poses = applyTransform(e.ape.transform, est.poses);
  }
  return evaluateRelative(gt, config.ape_alignment == Alignment::Sim3 ? scaled : est, config, std::move(e));
}

namespace {

TrajectoryEvaluation evaluateRelative(const Trajectory& gt, const Trajectory& est,
                                      const TrajectoryEvalConfig& config, TrajectoryEvaluation e) {
  if (!(config.rpe.delta > 0) || !std::isfinite(config.rpe.delta))
    fail("rpe", "delta must be a positive number (got " + std::to_string(config.rpe.delta) + ")");
  // Too short for one RPE pair is a property of the data, not an error of the evaluation.
  const PoseVector P = applyTransform(alignmentFor(gt, est, config.rpe.alignment), est.poses);
  const bool has_pair =
      config.rpe.unit == DeltaUnit::Metres
          ? !rpePairsByPath(P, config.rpe.delta).empty()
          : !rpePairsByFrames(P.size(), static_cast<std::size_t>(config.rpe.delta)).empty();
  if (has_pair) e.rpe = computeRpe(gt, est, config.rpe);
  e.kitti = computeKittiErrors(gt, est, config.kitti);
  return e;
}

}  // namespace

namespace {
nlohmann::json statsJson(const ErrorStats& s) {
  return {{"count", s.count}, {"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median},
          {"std", s.std},     {"min", s.min},   {"max", s.max}};
}
}  // namespace

std::string toJson(const TrajectoryEvaluation& e, int indent) {
  nlohmann::json j;
  j["poses"] = e.poses;
  j["gt_length_m"] = e.gt_length_m;
  j["est_length_m"] = e.est_length_m;
  nlohmann::json ape = statsJson(e.ape.translation);
  ape["alignment"] = toString(e.ape.alignment);
  ape["scale"] = e.ape.transform.scale;
  ape["rot_rmse_deg"] = e.ape.rotation_deg.rmse;
  ape["rot_mean_deg"] = e.ape.rotation_deg.mean;
  j["ape"] = ape;
  if (e.rpe) {
    nlohmann::json rpe = statsJson(e.rpe->translation);
    rpe["delta"] = e.rpe->config.delta;
    rpe["unit"] = e.rpe->config.unit == DeltaUnit::Metres ? "m" : "frames";
    rpe["alignment"] = toString(e.rpe->config.alignment);
    rpe["pairs"] = e.rpe->pairs.size();
    rpe["rot_rmse_deg"] = e.rpe->rotation_deg.rmse;
    rpe["rot_mean_deg"] = e.rpe->rotation_deg.mean;
    j["rpe"] = rpe;
  } else {
    j["rpe"] = nullptr;
  }
  nlohmann::json kitti;
  kitti["segments"] = e.kitti.segments;
  kitti["t_err_pct"] = e.kitti.segments ? nlohmann::json(e.kitti.t_err_pct) : nlohmann::json();
  kitti["r_err_deg_per_100m"] =
      e.kitti.segments ? nlohmann::json(e.kitti.r_err_deg_per_100m) : nlohmann::json();
  nlohmann::json per = nlohmann::json::array();
  for (const auto& l : e.kitti.per_length)
    per.push_back({{"length_m", l.length},
                   {"segments", l.segments},
                   {"t_err_pct", l.t_err_pct},
                   {"r_err_deg_per_100m", l.r_err_deg_per_100m}});
  kitti["per_length"] = per;
  j["kitti"] = kitti;
  return j.dump(indent);
}

std::string toText(const TrajectoryEvaluation& e) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(6);
  s << "poses            " << e.poses << " (ground truth " << e.gt_length_m << " m, estimate "
    << e.est_length_m << " m)\n";
  const auto& a = e.ape.translation;
  s << "APE (" << toString(e.ape.alignment);
  if (e.ape.alignment == Alignment::Sim3) s << ", scale " << e.ape.transform.scale;
  s << ") [m]  rmse " << a.rmse << "  mean " << a.mean << "  median " << a.median << "  std "
    << a.std << "  min " << a.min << "  max " << a.max << "\n";
  if (e.rpe) {
    const auto& r = e.rpe->translation;
    std::ostringstream delta;
    delta << e.rpe->config.delta;  // default float format: "10", "0.5"
    s << "RPE (delta " << delta.str()
      << (e.rpe->config.unit == DeltaUnit::Metres ? " m" : " frames") << ", " << e.rpe->pairs.size()
      << " pairs) [m]  rmse " << r.rmse << "  mean " << r.mean << "  median " << r.median
      << "  std " << r.std << "  min " << r.min << "  max " << r.max << "  (rot rmse "
      << e.rpe->rotation_deg.rmse << " deg)\n";
  } else {
    s << "RPE              no pair (trajectory shorter than delta)\n";
  }
  if (e.kitti.segments) {
    s.precision(4);
    s << "KITTI segments   " << e.kitti.segments << ": t_err " << e.kitti.t_err_pct
      << " %  r_err " << e.kitti.r_err_deg_per_100m << " deg/100m\n";
  } else {
    s << "KITTI segments   none (ground truth shorter than the shortest segment)\n";
  }
  return s.str();
}

}  // namespace hazmap
