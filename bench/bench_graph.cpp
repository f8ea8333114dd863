// Pose-graph optimisation speed and final cost, in one run:
//   hazmap            chordal initialisation + LM on the chordal cost (library defaults), 1 and 2
//                     threads; and geodesic LM from the file's vertices (same start as Ceres).
//   ceres_plain       a plain Ceres set-up like Ceres' documented pose_graph_3d / pose_graph_2d
//                     examples: quaternion manifold (angle for 2-D), g2o-style residual
//                     [R_aᵀ(p_b − p_a) − p̃; 2 vec(q̃ ⊗ q_ab⁻¹)] (yaw difference in 2-D) weighted by
//                     the file's information, autodiff, sparse normal Cholesky, LM, from the file's
//                     vertices (composed odometry when the file has none), 200 iterations at most.
//   open3d            Open3D GlobalOptimization (LM), small 3-D graphs only (it builds dense
//                     matrices: minutes and gigabytes on sphere2500, out of memory on torus3D).
// Every run reports the final SE-Sync objective F (counter "F") and, where SE-Sync published the
// global optimum F*, "dF_pct" = 100 (F − F*) / F*. GTSAM's published times (SE-Sync paper,
// Table 2, Dog-Leg + chordal init, 2.8 GHz laptop) for reference: sphere2500 0.70 s, torus3D
// 1.96 s.
#include <benchmark/benchmark.h>

#include "hazmap/core/memory.hpp"
#include <ceres/ceres.h>

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <string>

#include "hazmap/graph/optimizer.hpp"
#include "hazmap/graph/g2o.hpp"

#ifdef HAZMAP_BENCH_HAVE_OPEN3D
#include <open3d/pipelines/registration/GlobalOptimization.h>
#include <open3d/pipelines/registration/PoseGraph.h>
#include <open3d/utility/Logging.h>
#endif

namespace {

using hazmap::PoseGraph;

const std::map<std::string, double> kFStar = {
    {"sphere2500", 1.687e3}, {"torus3D", 2.423e4}, {"manhattan", 6.432e3}, {"CSAIL", 3.170e1}};

const PoseGraph& loadGraph(const std::string& name) {
  static std::map<std::string, PoseGraph> cache;
  auto it = cache.find(name);
  if (it == cache.end())
    it = cache.emplace(name, hazmap::readG2o(std::string(HAZMAP_SHARED_DATA_DIR) +
                                             "/pose-graphs/" + name + ".g2o"))
             .first;
  return it->second;
}

void reportCost(benchmark::State& state, const std::string& name, const PoseGraph& result,
                int iterations) {
  const double F = hazmap::chordalCost(result);
  state.counters["F"] = F;
  state.counters["iters"] = iterations;
  const auto f = kFStar.find(name);
  if (f != kFStar.end()) state.counters["dF_pct"] = 100.0 * (F - f->second) / f->second;
}

// ---- hazmap ----------------------------------------------------------------------------------

void BM_hazmap(benchmark::State& state, std::string name, hazmap::PoseGraphCost cost,
               hazmap::PoseGraphInit init, int threads) {
  const PoseGraph& original = loadGraph(name);
  PoseGraph result;
  int iterations = 0;
  for (auto _ : state) {
    state.PauseTiming();
    PoseGraph g = original;
    state.ResumeTiming();
    hazmap::PoseGraphConfig c;
    c.cost = cost;
    c.init = init;
    c.loop_loss = hazmap::LoopLoss::None;
    c.threads = threads;
    iterations = hazmap::optimizePoseGraph(g, c).iterations;
    state.PauseTiming();
    result = std::move(g);
    state.ResumeTiming();
  }
  reportCost(state, name, result, iterations);
}

// ---- plain Ceres (pose_graph_3d / pose_graph_2d style) ---------------------------------------

struct G2oStyleError3 {
  G2oStyleError3(const Eigen::Vector3d& p, const Eigen::Quaterniond& q, const hazmap::Matrix6d& U)
      : p_(p), q_(q), U_(U) {}
  template <typename T>
  bool operator()(const T* pa, const T* qa, const T* pb, const T* qb, T* out) const {
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_a(pa), p_b(pb);
    Eigen::Map<const Eigen::Quaternion<T>> q_a(qa), q_b(qb);
    const Eigen::Quaternion<T> q_a_inv = q_a.conjugate();
    const Eigen::Quaternion<T> q_ab = q_a_inv * q_b;
    const Eigen::Matrix<T, 3, 1> p_ab = q_a_inv * (p_b - p_a);
    const Eigen::Quaternion<T> dq = q_.template cast<T>() * q_ab.conjugate();
    Eigen::Matrix<T, 6, 1> r;
    r.template head<3>() = p_ab - p_.template cast<T>();
    r.template tail<3>() = T(2.0) * dq.vec();
    Eigen::Map<Eigen::Matrix<T, 6, 1>>{out} = U_.template cast<T>() * r;
    return true;
  }
  Eigen::Vector3d p_;
  Eigen::Quaterniond q_;
  hazmap::Matrix6d U_;
};

template <typename T>
T normalizeAngle(const T& a) {
  const T two_pi(2.0 * M_PI);
  return a - two_pi * ceres::floor((a + T(M_PI)) / two_pi);
}

struct G2oStyleError2 {
  G2oStyleError2(double x, double y, double th, const Eigen::Matrix3d& U)
      : x_(x), y_(y), th_(th), U_(U) {}
  template <typename T>
  bool operator()(const T* xa, const T* ya, const T* tha, const T* xb, const T* yb, const T* thb,
                  T* out) const {
    const T c = ceres::cos(*tha), s = ceres::sin(*tha);
    const T dx = *xb - *xa, dy = *yb - *ya;
    Eigen::Matrix<T, 3, 1> r;
    r(0) = c * dx + s * dy - T(x_);
    r(1) = -s * dx + c * dy - T(y_);
    r(2) = normalizeAngle(*thb - *tha - T(th_));
    Eigen::Map<Eigen::Matrix<T, 3, 1>>{out} = U_.template cast<T>() * r;
    return true;
  }
  double x_, y_, th_;
  Eigen::Matrix3d U_;
};

void BM_ceres_plain(benchmark::State& state, std::string name, int threads) {
  const PoseGraph& original = loadGraph(name);
  const bool planar = original.dimension == 2;
  PoseGraph result = original;
  int iterations = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const int n = original.numNodes();
    std::vector<double> pos(3 * n), rot(4 * n);  // 3-D: p, q (x y z w); 2-D: x, y, yaw
    for (int i = 0; i < n; ++i) {
      const auto& T = original.poses[i];
      if (planar) {
        pos[3 * i] = T.translation().x();
        pos[3 * i + 1] = T.translation().y();
        pos[3 * i + 2] = hazmap::yawOf(T);
      } else {
        Eigen::Map<Eigen::Vector3d>{&pos[3 * i]} = T.translation();
        Eigen::Map<Eigen::Quaterniond>{&rot[4 * i]} = Eigen::Quaterniond(T.linear());
      }
    }
    state.ResumeTiming();
    ceres::Problem problem;
    ceres::Manifold* quaternion = new ceres::EigenQuaternionManifold;  // owned by problem
    for (const auto& e : original.edges) {
      const hazmap::Matrix6d info = hazmap::informationLeftToRight(e.T_from_to, e.information);
      const int a = e.from, b = e.to;
      if (planar) {
        Eigen::Matrix3d I3;
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) I3(r, c) = info(hazmap::kPlanarIndex[r], hazmap::kPlanarIndex[c]);
        const Eigen::Matrix3d U = Eigen::LLT<Eigen::Matrix3d>(I3).matrixU();
        auto* f = new ceres::AutoDiffCostFunction<G2oStyleError2, 3, 1, 1, 1, 1, 1, 1>(
            new G2oStyleError2(e.T_from_to.translation().x(), e.T_from_to.translation().y(),
                               hazmap::yawOf(e.T_from_to), U));
        problem.AddResidualBlock(f, nullptr, &pos[3 * a], &pos[3 * a + 1], &pos[3 * a + 2],
                                 &pos[3 * b], &pos[3 * b + 1], &pos[3 * b + 2]);
      } else {
        const hazmap::Matrix6d U = Eigen::LLT<hazmap::Matrix6d>(info).matrixU();
        auto* f = new ceres::AutoDiffCostFunction<G2oStyleError3, 6, 3, 4, 3, 4>(
            new G2oStyleError3(e.T_from_to.translation(), Eigen::Quaterniond(e.T_from_to.linear()),
                               U));
        problem.AddResidualBlock(f, nullptr, &pos[3 * a], &rot[4 * a], &pos[3 * b], &rot[4 * b]);
        problem.SetManifold(&rot[4 * a], quaternion);
        problem.SetManifold(&rot[4 * b], quaternion);
      }
    }
    const int fixed = original.fixed_node;
    if (planar) {
      for (int k = 0; k < 3; ++k) problem.SetParameterBlockConstant(&pos[3 * fixed + k]);
    } else {
      problem.SetParameterBlockConstant(&pos[3 * fixed]);
      problem.SetParameterBlockConstant(&rot[4 * fixed]);
    }
    ceres::Solver::Options options;
    options.max_num_iterations = 200;
    options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    options.num_threads = threads;
    options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
    state.PauseTiming();
    iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
    for (int i = 0; i < n; ++i) {
      if (planar) {
        result.poses[i] = hazmap::fromXyYaw(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]);
      } else {
        Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
        T.translation() = Eigen::Map<Eigen::Vector3d>(&pos[3 * i]);
        T.linear() = Eigen::Map<Eigen::Quaterniond>(&rot[4 * i]).normalized().toRotationMatrix();
        result.poses[i] = T;
      }
    }
    state.ResumeTiming();
  }
  reportCost(state, name, result, iterations);
}

// ---- Open3D ----------------------------------------------------------------------------------

#ifdef HAZMAP_BENCH_HAVE_OPEN3D
void BM_open3d(benchmark::State& state, std::string name) {
  namespace reg = open3d::pipelines::registration;
  open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
  const PoseGraph& original = loadGraph(name);
  PoseGraph result = original;
  for (auto _ : state) {
    state.PauseTiming();
    reg::PoseGraph pg;
    for (const auto& T : original.poses) pg.nodes_.emplace_back(T.matrix());
    // Open3D: edge (source, target) with T_target_source, information rotation first.
    for (const auto& e : original.edges)
      pg.edges_.emplace_back(e.to, e.from, e.T_from_to.matrix(),
                             hazmap::swapTranslationRotation(
                                 hazmap::informationLeftToRight(e.T_from_to, e.information)),
                             false);
    state.ResumeTiming();
    reg::GlobalOptimization(pg, reg::GlobalOptimizationLevenbergMarquardt(),
                            reg::GlobalOptimizationConvergenceCriteria(),
                            reg::GlobalOptimizationOption(0.075, 0.25, 1.0, original.fixed_node));
    state.PauseTiming();
    for (std::size_t i = 0; i < pg.nodes_.size(); ++i)
      result.poses[i] = hazmap::normalized(Eigen::Isometry3d(pg.nodes_[i].pose_));
    state.ResumeTiming();
  }
  reportCost(state, name, result, 0);
}
#endif

void registerAll() {
  using hazmap::PoseGraphCost;
  using hazmap::PoseGraphInit;
  struct G {
    const char* name;
    bool big;
    bool three_d;
  };
  const G graphs[] = {{"tinyGrid3D", false, true}, {"smallGrid3D", false, true},
                      {"CSAIL", false, false},     {"manhattan", true, false},
                      {"sphere2500", true, true},  {"torus3D", true, true}};
  for (const G& g : graphs) {
    const std::string n = g.name;
    auto tune = [&](benchmark::internal::Benchmark* b, int iters) {
      b->Unit(benchmark::kMillisecond)->UseRealTime();
      if (g.big) b->Iterations(iters);
    };
    tune(benchmark::RegisterBenchmark(("hazmap_chordal/" + n + "/threads:1").c_str(), BM_hazmap,
                                      n, PoseGraphCost::Chordal, PoseGraphInit::Chordal, 1),
         3);
    tune(benchmark::RegisterBenchmark(("hazmap_chordal/" + n + "/threads:2").c_str(), BM_hazmap,
                                      n, PoseGraphCost::Chordal, PoseGraphInit::Chordal, 2),
         3);
    if (g.three_d)
      tune(benchmark::RegisterBenchmark(("hazmap_geodesic_from_file/" + n).c_str(), BM_hazmap, n,
                                        PoseGraphCost::Geodesic, PoseGraphInit::AsIs, 1),
           1);
    tune(benchmark::RegisterBenchmark(("ceres_plain/" + n + "/threads:1").c_str(), BM_ceres_plain,
                                      n, 1),
         1);
#ifdef HAZMAP_BENCH_HAVE_OPEN3D
    if (!g.big && g.three_d)
      tune(benchmark::RegisterBenchmark(("open3d/" + n).c_str(), BM_open3d, n), 1);
#endif
  }
}

}  // namespace

int main(int argc, char** argv) {
  hazmap::retainFreedMemory();  // as the CLI does (core/memory.hpp)
  registerAll();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
