// The ICP loop: correspondences by the paper's rule (eq. 2, RegistrationTarget::match), robust
// weights with an adaptive scale, a weighted point-to-point closed form (eq. 1) or a point-to-plane
// Gauss–Newton step, and the pose covariance at the solution.
//
// Determinism: the source is cut into fixed chunks; each chunk's partial sums are computed in
// parallel and added in chunk order, so results do not depend on the number of threads.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "hazmap/core/error.hpp"
#include "hazmap/registration/covariance.hpp"
#include "hazmap/registration/registration.hpp"
#include "hazmap/registration/registration_target.hpp"
#include "thread_arena.hpp"

namespace hazmap {

namespace {

constexpr std::size_t kChunk = 512;
constexpr std::size_t kSearchGrain = 64;

struct Corr {
  std::int32_t target = -1;
  float distance2 = 0.0f;
  float residual = 0.0f;  ///< signed point-to-plane distance, or |p − q| for point-to-point
  float weight = 1.0f;    ///< class / soft-label weight (robust weight applied later)
  bool cross = false;
  bool point3 = false;    ///< 3-D point-to-point residual (point metric, or a property pair)
  bool anisotropic = false;  ///< property pair with a target normal: in-plane part down-weighted
  std::uint8_t group = 0; ///< 0 ordinary pair, 1 property point matched to its class
};

// Partial sums of one chunk. Point-to-point also accumulates centroids and the cross-covariance.
struct Sums {
  Matrix6d H = Matrix6d::Zero();  ///< Σ w JᵀJ (without property pairs' in-plane parts)
  Vector6d g = Vector6d::Zero();  ///< Σ w Jᵀ r
  Matrix6d Ht = Matrix6d::Zero();  ///< property pairs' in-plane parts (see TangentMix)
  Vector6d gt = Vector6d::Zero();
  double wr2 = 0.0, w = 0.0, w1 = 0.0, w3 = 0.0, d2 = 0.0, r2 = 0.0;
  std::size_t n = 0;
  Eigen::Vector3d sp = Eigen::Vector3d::Zero(), sq = Eigen::Vector3d::Zero();
  Eigen::Matrix3d spq = Eigen::Matrix3d::Zero();
  void add(const Sums& o) {
    H += o.H; g += o.g; Ht += o.Ht; gt += o.gt;
    wr2 += o.wr2; w += o.w; w1 += o.w1; w3 += o.w3; d2 += o.d2; r2 += o.r2; n += o.n;
    sp += o.sp; sq += o.sq; spq += o.spq;
  }
};

// A property pair's 3-D residual r = p − q with its in-plane part scaled by `s`:
// M r, M = n nᵀ + s (I − n nᵀ). Used for the robust weight of the pair.
Eigen::Vector3f weightedResidual(const Eigen::Vector3f& r, const Eigen::Vector3f& n, double s) {
  const Eigen::Vector3f along = n * n.dot(r);
  return along + static_cast<float>(s) * (r - along);
}

// How a property pair's in-plane information enters the normal equations. In-plane, a labelled
// point and its same-class partner are apart mostly because the scans sampled the patch at
// different spots, so that information gets the small weight w_t — except along directions that
// the rest (plane residuals, along-normal parts) leaves unconstrained, where it is the only
// information there is and gets full weight. With S = diag(1,1,1,1/L,1/L,1/L) and P the
// projector on the degenerate eigenvectors of S·H_geometry·S, a tangent block X becomes
// S⁻¹ (w_t X_s + (1 − w_t) P X_s P) S⁻¹ with X_s = S X S (and g → S⁻¹ (w_t I + (1 − w_t) P) S g).
struct TangentMix {
  double w_t = 1.0;
  Vector6d d = Vector6d::Ones();  ///< diagonal of S
  Matrix6d P = Matrix6d::Zero();
  TangentMix() = default;
  TangentMix(const Matrix6d& H_geometry, double pairs_weight, double w_tangent, double length,
             double threshold)
      : w_t(w_tangent) {
    const double L = length > 0.0 ? length : 1.0;
    d << 1, 1, 1, 1.0 / L, 1.0 / L, 1.0 / L;
    const Matrix6d Hs = d.asDiagonal() * H_geometry * d.asDiagonal();
    const Eigen::SelfAdjointEigenSolver<Matrix6d> es(0.5 * (Hs + Hs.transpose()));
    for (int i = 0; i < 6; ++i)
      if (es.eigenvalues()(i) < threshold * pairs_weight)
        P.noalias() += es.eigenvectors().col(i) * es.eigenvectors().col(i).transpose();
  }
  Matrix6d operator()(const Matrix6d& X) const {
    const Matrix6d Xs = d.asDiagonal() * X * d.asDiagonal();
    const Matrix6d mixed = w_t * Xs + (1.0 - w_t) * P * Xs * P;
    const Vector6d di = d.cwiseInverse();
    return di.asDiagonal() * mixed * di.asDiagonal();
  }
  Vector6d operator()(const Vector6d& g) const {
    const Vector6d gs = d.asDiagonal() * g;
    return d.cwiseInverse().asDiagonal() * Vector6d(w_t * gs + (1.0 - w_t) * (P * gs));
  }
};

// Weight w(s) = ψ(s)/s and the derivative factor ψ'(s)/w(s) − 1 = s·w'(s)/w(s) (for the bread).
double robustWeight(RobustKernel kernel, double r, double k) {
  switch (kernel) {
    case RobustKernel::None: return 1.0;
    case RobustKernel::Huber: return std::abs(r) <= k ? 1.0 : k / std::abs(r);
    case RobustKernel::GemanMcClure: {
      const double a = k * k / (k * k + r * r);
      return a * a;
    }
  }
  return 1.0;
}

double robustSlope(RobustKernel kernel, double s, double k) {
  switch (kernel) {
    case RobustKernel::None: return 0.0;
    case RobustKernel::Huber: return std::abs(s) <= k ? 0.0 : -1.0;
    case RobustKernel::GemanMcClure: return -4.0 * s * s / (k * k + s * s);
  }
  return 0.0;
}

using detail::runWithThreads;

}  // namespace

RegistrationResult registerClouds(const LabeledCloud& source, const LabeledCloud& target,
                                  const Eigen::Isometry3d& initial_guess, const ClassTable& classes,
                                  const RegistrationConfig& config) {
  config.validate();
  if (!isFinite(initial_guess)) fail("registration", "initial guess has a non-finite entry");
  RegistrationResult result;
  runWithThreads(config.threads, [&] {
    const RegistrationTarget prepared(target, classes, config);
    result = registerClouds(source, prepared, initial_guess, classes, config);
  });
  return result;
}

namespace {

std::vector<char> propertyFlags(const ClassTable& classes) {
  std::vector<char> is_property;
  for (ClassId id : classes.ids()) {
    if (is_property.size() <= id) is_property.resize(std::size_t(id) + 1, 0);
    is_property[id] = classes.isProperty(id);
  }
  return is_property;
}

// Label gate: do the labels agree with the target's where the geometry pairs points up? Each
// labelled source point (placed with T) is paired with its nearest target point of any class;
// the agreement rate is corrected for chance (Cohen's κ against the target's class shares).
// Random labels give κ ≈ 0. NaN with fewer than min_label_pairs pairs.
double labelAgreement(const LabeledCloud& source, const RegistrationTarget& target,
                      const Eigen::Isometry3d& T, const std::vector<char>& is_property,
                      std::size_t min_pairs) {
  std::vector<double> share;
  std::size_t paired = 0;
  double agree = 0.0, chance = 0.0;
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  for (std::size_t i = 0; i < source.size(); ++i) {
    const ClassId cls = source.classes[i];
    if (cls >= is_property.size() || !is_property[cls] || !source.points[i].allFinite()) continue;
    const TargetMatch m = target.nearestAnyClass(R * source.points[i] + t, cls);
    if (m.index < 0) continue;
    if (share.size() <= cls) share.resize(std::size_t(cls) + 1, -1.0);
    if (share[cls] < 0.0) share[cls] = target.classShare(cls);
    ++paired;
    agree += !m.cross_class;
    chance += share[cls];
  }
  if (paired < std::max<std::size_t>(min_pairs, 1)) return std::numeric_limits<double>::quiet_NaN();
  const double a = agree / static_cast<double>(paired), e = chance / static_cast<double>(paired);
  return e < 1.0 ? (a - e) / (1.0 - e) : 1.0;
}

// One ICP run (with its coarse stage, see coarse_source_points). `covariance` = false leaves the
// result's covariance, Hessian and degenerate directions at their "unknown" defaults.
RegistrationResult solve(const LabeledCloud& source, const RegistrationTarget& target,
                         const Eigen::Isometry3d& initial_guess, const ClassTable& classes,
                         const RegistrationConfig& config, bool use_labels, bool covariance = true) {
  RegistrationResult result;
  result.transform = initial_guess;
  result.covariance = Matrix6d::Identity() * 1e6;  // "unknown" until a solution exists

  // Source points used: finite, evenly strided down to max_source_points.
  std::vector<std::uint32_t> used;
  used.reserve(source.size());
  for (std::size_t i = 0; i < source.size(); ++i)
    if (source.points[i].allFinite()) used.push_back(static_cast<std::uint32_t>(i));
  if (config.max_source_points > 0 && used.size() > config.max_source_points) {
    std::vector<std::uint32_t> strided(config.max_source_points);
    const double step = static_cast<double>(used.size()) / static_cast<double>(config.max_source_points);
    for (std::size_t k = 0; k < strided.size(); ++k) strided[k] = used[static_cast<std::size_t>(k * step)];
    used.swap(strided);
  }
  result.stats.source_points = used.size();
  if (used.empty()) {
    result.reason = "empty source cloud";
    return result;
  }
  if (target.empty()) {
    result.reason = "empty target cloud";
    return result;
  }
  if (used.size() < config.min_correspondences) {
    result.reason = "source has only " + std::to_string(used.size()) +
                    " points (min_correspondences = " + std::to_string(config.min_correspondences) + ")";
    return result;
  }

  // Coarse to fine (coarse_source_points): the far-moving early steps on a strided subset, then
  // the full source from where they ended. A coarse stage that failed leaves the guess as it was.
  Eigen::Isometry3d start = initial_guess;
  if (config.coarse_source_points > 0 && used.size() >= 4 * config.coarse_source_points) {
    RegistrationConfig coarse = config;
    coarse.coarse_source_points = 0;
    coarse.max_source_points = config.coarse_source_points;
    coarse.translation_tolerance = 10.0 * config.translation_tolerance;
    coarse.rotation_tolerance = 10.0 * config.rotation_tolerance;
    // Only its pose is used: no covariance pass (a serial loop and a target-sized buffer).
    const RegistrationResult c = solve(source, target, initial_guess, classes, coarse, use_labels,
                                       /*covariance=*/false);
    result.coarse_iterations = c.iterations;
    const bool hit_limit = c.reason.rfind("reached max_iterations", 0) == 0;
    if ((c.converged || hit_limit) && isFinite(c.transform)) start = c.transform;
  }

  const bool plane = config.metric == IcpMetric::PointToPlane;
  const LabeledCloud& tc = target.cloud();
  // Normals are read raw after the correspondence pass, which asked for (and so estimated) every
  // paired point's normal (target.normal: lazy ones are estimated on first use).
  const auto& normals = target.normalsComputed();
  const bool use_value = target.usesProperty() && source.hasProperty();
  const bool soft = config.use_classes && config.label_mode == LabelMode::Soft;
  const float mismatch_weight = soft ? static_cast<float>(1.0 - config.label_confidence * config.label_confidence) : 1.0f;
  // Class weights per source class id (1 when off or unknown).
  std::vector<float> class_weight;
  const std::vector<char> is_property = propertyFlags(classes);
  const bool property_point = use_labels && config.property_point_to_point;
  const double tangent_scale = std::sqrt(config.property_tangent_weight);
  if (config.use_classes && config.use_class_weights) {
    for (ClassId id : classes.ids()) {
      if (class_weight.size() <= id) class_weight.resize(std::size_t(id) + 1, 1.0f);
      class_weight[id] = static_cast<float>(classes.at(id).weight);
    }
  }

  const std::size_t n = used.size();
  result.labels_used = use_labels;
  // Farthest used source point from the sensor: a pose change D (source frame) moves every point
  // by at most |t_D| + angle(D)·reach (bounds how far points moved since the last search).
  double reach = 0.0;
  bool labelled_points = false;
  for (const std::uint32_t i : used) {
    reach = std::max(reach, static_cast<double>(source.points[i].norm()));
    const ClassId c = source.classes[i];
    labelled_points = labelled_points || (c < is_property.size() && is_property[c]);
  }
  // Reused correspondences only without labels in play: the labelled pairs' wide same-class
  // search reacts to small moves, and freezing it cost property ICP accuracy on the simulated
  // tanks run (map error 0.077 → 0.140 m; re-searching just the labelled points oscillated).
  const bool reuse_allowed = !(use_labels && labelled_points);

  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<Corr> corr(n);
  std::vector<Sums> partial(chunks);
  std::vector<float> abs_res;
  abs_res.reserve(n);
  Eigen::Isometry3d T = start;
  Eigen::Isometry3d T_corr = T;  // the pose at which `corr` was computed
  Sums total;
  TangentMix mix;  // of the last iteration (the covariance uses it too)
  double kernel[2] = {0.0, 0.0};

  // One correspondence search at T (steps 1 and 2); false when too few pairs were found (the
  // reason is set). `it` numbers the search for that message.
  const auto search = [&](int it) {
    const Eigen::Matrix3f R = T.linear().cast<float>();
    const Eigen::Vector3f t = T.translation().cast<float>();
    T_corr = T;
    // 1. correspondences (the expensive part; each point on its own, so finer grains than the
    //    sums' chunks balance the threads better on small sources without changing a bit)
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kSearchGrain), [&](const auto& range) {
      for (std::size_t k = range.begin(); k < range.end(); ++k) {
        const std::uint32_t i = used[k];
        const Eigen::Vector3f p = R * source.points[i] + t;
        const ClassId cls = source.classes[i];
        const float value = use_value ? source.property[i] : std::numeric_limits<float>::quiet_NaN();
        Corr& cr = corr[k];
        // The previous iteration's partner bounds the search (exact, see costBound).
        const float bound = target.costBound(p, cls, cr.target, use_labels);
        const TargetMatch m = use_labels ? target.match(p, cls, value, bound)
                                         : target.nearestAnyClass(p, cls, bound);
        cr.target = static_cast<std::int32_t>(m.index);
        if (m.index < 0) continue;
        // A same-class property pair constrains where the labelled patch is, which a plane
        // residual would throw away (a patch lies in its wall): it gets a 3-D residual.
        const bool own_property = use_labels && !m.cross_class && is_property[cls];
        cr.point3 = !plane || (property_point && own_property);
        const Eigen::Vector3f& nq = plane ? target.normal(m.index) : p;  // p: unused
        cr.anisotropic = plane && cr.point3 && tangent_scale < 1.0 && !nq.isZero();
        cr.group = own_property ? 1 : 0;
        if (cr.anisotropic) {
          cr.residual = weightedResidual(p - tc.points[m.index], nq, tangent_scale).norm();
        } else if (!cr.point3) {
          if (nq.isZero()) {  // no normal there: unusable for point-to-plane
            cr.target = -1;
            continue;
          }
          cr.residual = nq.dot(p - tc.points[m.index]);
        } else {
          cr.residual = std::sqrt(m.distance2);
        }
        cr.distance2 = m.distance2;
        cr.cross = m.cross_class;
        cr.weight = use_labels && cls < class_weight.size() ? class_weight[cls] : 1.0f;
        if (m.cross_class && soft && use_labels) cr.weight *= mismatch_weight;
      }
    });
    // 2. adaptive robust scale from the observed residuals (median absolute residual), separately
    //    for ordinary pairs and for property pairs (few, larger residuals, and the ones that
    //    carry the label's information — one shared scale would silence them).
    std::size_t matched_now = 0;
    for (int grp = 0; grp < 2; ++grp) {
      abs_res.clear();
      bool p3 = !plane;
      for (std::size_t k = 0; k < n; ++k)
        if (corr[k].target >= 0 && corr[k].group == grp) {
          abs_res.push_back(std::abs(corr[k].residual));
          p3 = corr[k].point3;
        }
      matched_now += abs_res.size();
      if (abs_res.empty()) continue;
      const std::size_t mid = abs_res.size() / 2;
      std::nth_element(abs_res.begin(), abs_res.begin() + mid, abs_res.end());
      // |r| of a 1-D Gaussian has median 0.6745σ; the norm of a 3-D one 1.5382σ.
      const double sigma = abs_res[mid] / (p3 ? 1.5382 : 0.6745);
      kernel[grp] = std::max(config.robust_min_scale, config.robust_scale_factor * sigma);
    }
    if (matched_now < config.min_correspondences) {
      result.reason = "only " + std::to_string(matched_now) + " correspondences at iteration " +
                      std::to_string(it + 1) + " (min_correspondences = " +
                      std::to_string(config.min_correspondences) + ")";
      result.iterations = it + 1;
      total = Sums{};
      return false;
    }
    return true;
  };

  const auto run = [&] {
    // An iteration is one correspondence search followed by Gauss-Newton steps: the first, plus
    // reweighting steps on the same correspondences while the points have hardly moved
    // (correspondence_reuse_distance; at most kMaxReuseSteps). max_iterations counts searches.
    constexpr int kMaxReuseSteps = 10;
    bool fresh = true;  // search correspondences for this step (else reuse the last ones)
    int it = -1, reuse_steps = 0;
    while (true) {
      if (fresh) {
        if (++it == config.max_iterations) break;
        reuse_steps = 0;
        if (!search(it)) return;
      }
      // 3. weighted normal equations, chunk by chunk (residuals and robust weights at the current
      //    pose: the same as the searched ones on a fresh iteration, updated when reused)
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const auto& range) {
        for (std::size_t c = range.begin(); c < range.end(); ++c) {
          Sums s;
          const std::size_t end = std::min(n, (c + 1) * kChunk);
          for (std::size_t k = c * kChunk; k < end; ++k) {
            const Corr& cr = corr[k];
            if (cr.target < 0) continue;
            const double ks = kernel[cr.group];
            const Eigen::Vector3d p = T * source.points[used[k]].cast<double>();
            const Eigen::Vector3d q = tc.points[cr.target].cast<double>();
            double residual = cr.residual;
            if (!fresh) {
              if (cr.anisotropic)
                residual = weightedResidual((p - q).cast<float>(), normals[cr.target], tangent_scale).norm();
              else if (!cr.point3)
                residual = normals[cr.target].cast<double>().dot(p - q);
              else
                residual = (p - q).norm();
            }
            const double w = cr.weight * robustWeight(config.robust_kernel, residual, ks);
            ++s.n;
            s.d2 += cr.distance2;
            if (!(w > 0.0)) continue;
            if (!cr.point3) {
              const Eigen::Vector3d nq = normals[cr.target].cast<double>();
              Vector6d J;
              J << nq, p.cross(nq);  // d r / d ξ for T' = exp(ξ) T, translation first
              const double r = residual;
              s.H.noalias() += w * J * J.transpose();
              s.g.noalias() += w * r * J;
              s.wr2 += w * r * r;
              s.r2 += r * r;
              s.w1 += w;
            } else {
              const Eigen::Vector3d r = p - q;
              Eigen::Matrix<double, 3, 6> J;
              J << Eigen::Matrix3d::Identity(), -hat(p);
              double rn2 = r.squaredNorm();
              if (cr.anisotropic) {
                const Eigen::Vector3d nq = normals[cr.target].cast<double>();
                const Vector6d Jn = J.transpose() * nq;
                const double rn = nq.dot(r);
                s.H.noalias() += w * Jn * Jn.transpose();
                s.g.noalias() += w * rn * Jn;
                const Eigen::Matrix3d Pt = Eigen::Matrix3d::Identity() - nq * nq.transpose();
                s.Ht.noalias() += w * (J.transpose() * Pt * J);
                s.gt.noalias() += w * (J.transpose() * (Pt * r));
                rn2 = rn * rn + config.property_tangent_weight * (rn2 - rn * rn);
              } else {
                s.H.noalias() += w * (J.transpose() * J);
                s.g.noalias() += w * (J.transpose() * r);
              }
              s.wr2 += w * rn2;
              s.r2 += rn2;
              s.w3 += w;
              s.sp += w * p;
              s.sq += w * q;
              s.spq.noalias() += w * p * q.transpose();
            }
            s.w += w;
          }
          partial[c] = s;
        }
      });
      total = Sums{};
      for (const Sums& s : partial) total.add(s);
      result.iterations = it + 1;
      if (!(total.w > 0.0)) {
        result.reason = "all correspondences were rejected by the robust kernel";
        return;
      }
      // 4. update
      Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
      if (plane) {
        mix = TangentMix(total.H, total.w, config.property_tangent_weight, config.degeneracy_length,
                         config.degeneracy_threshold);
        Matrix6d A = total.H + mix(total.Ht);
        total.g += mix(total.gt);
        A.diagonal().array() += 1e-9 * std::max(1.0, A.trace() / 6.0);  // guards exact degeneracy
        const Vector6d xi = A.ldlt().solve(-total.g);
        if (!xi.allFinite()) {
          result.reason = "the Gauss-Newton step was not finite";
          return;
        }
        delta = se3Exp(xi);
      } else {
        // Weighted closed form (Horn/Umeyama): q ≈ R p' + t.
        const Eigen::Vector3d mp = total.sp / total.w, mq = total.sq / total.w;
        const Eigen::Matrix3d C = total.spq / total.w - mp * mq.transpose();  // Σ w p qᵀ, centred
        Eigen::JacobiSVD<Eigen::Matrix3d> svd(C, Eigen::ComputeFullU | Eigen::ComputeFullV);
        Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
        if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0) D(2, 2) = -1;
        const Eigen::Matrix3d Rd = svd.matrixV() * D * svd.matrixU().transpose();
        delta.linear() = Rd;
        delta.translation() = mq - Rd * mp;
      }
      T = normalized(delta * T);
      const double dt = delta.translation().norm();
      const double dr = rotationAngle(delta);
      if (!isFinite(T)) {
        result.reason = "the estimate diverged (non-finite transform)";
        return;
      }
      if (dt < config.translation_tolerance && dr < config.rotation_tolerance) {
        if (fresh) {
          result.converged = true;
          return;
        }
        fresh = true;  // converged on reused correspondences: check against fresh ones
        continue;
      }
      const Eigen::Isometry3d moved = T_corr.inverse() * T;
      fresh = !reuse_allowed || ++reuse_steps > kMaxReuseSteps ||
              !(moved.translation().norm() + rotationAngle(moved) * reach < config.correspondence_reuse_distance);
    }
    result.reason = "reached max_iterations (" + std::to_string(config.max_iterations) + ")";
  };
  runWithThreads(config.threads, run);

  result.transform = isFinite(T) ? T : start;
  result.kernel_scale = kernel[0];
  // Statistics of the last correspondence set.
  std::size_t matched = 0, cross = 0, prop = 0, prop_matched = 0, wide = 0;
  const double r0 = config.max_correspondence_distance;
  for (std::size_t k = 0; k < n; ++k) {
    const bool is_prop = classes.isProperty(source.classes[used[k]]);
    prop += is_prop;
    if (corr[k].target < 0) continue;
    ++matched;
    cross += corr[k].cross;
    if (is_prop && !corr[k].cross) {
      ++prop_matched;
      wide += corr[k].distance2 > r0 * r0;
    }
  }
  result.stats.matched = matched;
  result.stats.cross_class = cross;
  result.stats.same_class = matched - cross;
  result.stats.property_points = prop;
  result.stats.property_matched = prop_matched;
  result.stats.wide_matches = wide;
  result.fitness = static_cast<double>(matched) / static_cast<double>(n);
  result.inlier_rmse = total.n > 0 ? std::sqrt(total.d2 / static_cast<double>(total.n)) : 0.0;
  if (covariance && total.w > 0.0) {
    // Covariance pass over the last correspondences (serial: cheap, and it needs per-target sums).
    // The meat is cluster-robust: residuals that share a target point share that point's noise,
    // so their score contributions are summed per target point before the outer product.
    Matrix6d bread = Matrix6d::Zero(), bread_t = Matrix6d::Zero(), meat = Matrix6d::Zero();
    std::vector<Vector6d> per_target(tc.size(), Vector6d::Zero());
    std::vector<char> touched(tc.size(), 0);
    double wr2 = 0.0, comps = 0.0, pairs = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
      const Corr& cr = corr[k];
      if (cr.target < 0) continue;
      const double ks = kernel[cr.group];
      const double w = cr.weight * robustWeight(config.robust_kernel, cr.residual, ks);
      if (!(w > 0.0)) continue;
      const Eigen::Vector3d p = T_corr * source.points[used[k]].cast<double>();
      Vector6d gi;
      if (!cr.point3) {
        const Eigen::Vector3d nq = normals[cr.target].cast<double>();
        Vector6d J;
        J << nq, p.cross(nq);
        const double r = cr.residual;
        bread.noalias() += w * (1.0 + robustSlope(config.robust_kernel, r, ks)) * J * J.transpose();
        gi = w * r * J;
        wr2 += w * r * r;
        comps += w;
      } else {
        const Eigen::Vector3d r = p - tc.points[cr.target].cast<double>();
        Eigen::Matrix<double, 3, 6> J;
        J << Eigen::Matrix3d::Identity(), -hat(p);
        if (cr.anisotropic) {
          // Along-normal part as a plane residual; the in-plane part mixed as in the solve.
          const Eigen::Vector3d nq = normals[cr.target].cast<double>();
          const Vector6d Jn = J.transpose() * nq;
          const double rn = nq.dot(r);
          const double rt2 = r.squaredNorm() - rn * rn;
          const Eigen::Matrix3d Pt = Eigen::Matrix3d::Identity() - nq * nq.transpose();
          bread.noalias() += w * Jn * Jn.transpose();
          bread_t.noalias() += w * (J.transpose() * Pt * J);
          gi = w * rn * Jn + mix(Vector6d(w * (J.transpose() * (Pt * r))));
          wr2 += w * (rn * rn + config.property_tangent_weight * rt2);
          comps += w * (1.0 + 2.0 * config.property_tangent_weight);
          pairs += w;
          per_target[cr.target] += gi;
          touched[cr.target] = 1;
          continue;
        }
        const double rn2 = r.squaredNorm();
        // ψ'(r) for a weight of |r|: w (I + slope · r rᵀ/|r|²)
        bread.noalias() += w * (J.transpose() * J);
        if (rn2 > 0.0) {
          const double slope = robustSlope(config.robust_kernel, std::sqrt(rn2), ks);
          const Vector6d Jr = J.transpose() * r;
          bread.noalias() += (w * slope / rn2) * Jr * Jr.transpose();
        }
        gi = w * (J.transpose() * r);
        wr2 += w * rn2;
        comps += 3.0 * w;
      }
      pairs += w;
      per_target[cr.target] += gi;
      touched[cr.target] = 1;
    }
    for (std::size_t j = 0; j < tc.size(); ++j)
      if (touched[j]) meat.noalias() += per_target[j] * per_target[j].transpose();
    bread += mix(bread_t);
    const Matrix6d H = total.H + mix(total.Ht);
    const PoseCovariance pc = poseCovariance(H, bread, meat, wr2, comps, pairs,
                                             config.degeneracy_length, config.degeneracy_threshold);
    result.hessian = H;
    result.covariance = pc.covariance;
    result.residual_sigma = pc.residual_sigma;
    result.degenerate_directions = pc.degenerate_directions;
  }
  return result;
}

}  // namespace

// The label gate around the solver. Labels agreeing at the initial guess are trusted outright.
// Otherwise the guess may simply be off by more than a patch (exactly when labels help), so the
// labelled solution is checked where it landed: labels that still disagree there are noise, and
// the registration is redone without them (plain ICP) — property ICP degrades to plain ICP
// instead of being pulled wherever wrong labels happen to cluster.
RegistrationResult registerClouds(const LabeledCloud& source, const RegistrationTarget& target,
                                  const Eigen::Isometry3d& initial_guess, const ClassTable& classes,
                                  const RegistrationConfig& config) {
  config.validate();
  if (!isFinite(initial_guess)) fail("registration", "initial guess has a non-finite entry");
  source.checkConsistent("registration source");
  if (config.use_classes) classes.checkCloud(source, "registration source");
  if (!target.compatibleWith(config, classes))
    fail("registration", "the prebuilt target was built with a different configuration or class table");
  if (!config.use_classes) return solve(source, target, initial_guess, classes, config, false);
  if (config.min_label_agreement <= -1.0) return solve(source, target, initial_guess, classes, config, true);

  const std::vector<char> is_property = propertyFlags(classes);
  const double before = labelAgreement(source, target, initial_guess, is_property, config.min_label_pairs);
  RegistrationResult labelled = solve(source, target, initial_guess, classes, config, true);
  labelled.label_agreement = before;
  if (std::isnan(before) || before >= config.min_label_agreement) return labelled;
  const double after = labelAgreement(source, target, labelled.transform, is_property, config.min_label_pairs);
  labelled.label_agreement = after;
  if (std::isnan(after) || after >= config.min_label_agreement) return labelled;
  RegistrationResult plain = solve(source, target, initial_guess, classes, config, false);
  plain.label_agreement = after;
  return plain;
}

}  // namespace hazmap
