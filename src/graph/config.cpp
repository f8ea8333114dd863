// PoseGraphConfig: its field table (core/config_fields.hpp) and the YAML loader derived from it.
#include "hazmap/core/config_fields.hpp"
#include "hazmap/graph/optimizer.hpp"
#include "hazmap/io/atomic_file.hpp"

namespace hazmap {

const ConfigFields<PoseGraphConfig>& configFields(ConfigTag<PoseGraphConfig>) {
  using C = PoseGraphConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Pose-graph optimisation (Ceres Levenberg–Marquardt).")
          .choice("cost", &C::cost, {{"geodesic", PoseGraphCost::Geodesic}, {"chordal", PoseGraphCost::Chordal}},
                  "geodesic (SE(3) log, information-weighted) or chordal (SE-Sync's objective)")
          .choice("init", &C::init,
                  {{"file", PoseGraphInit::AsIs}, {"odometry", PoseGraphInit::Odometry},
                   {"chordal", PoseGraphInit::Chordal}, {"as-is", PoseGraphInit::AsIs}, {"asis", PoseGraphInit::AsIs}},
                  "Initial poses: as given, composed odometry, or the chordal relaxation")
          .choice("loop_loss", &C::loop_loss,
                  {{"cauchy", LoopLoss::Cauchy}, {"none", LoopLoss::None}, {"dcs", LoopLoss::Dcs}},
                  "Robust loss on loop edges only")
          .number("loop_loss_scale", &C::loop_loss_scale, positive(), "Loss scale c in whitened units")
          .integer("max_iterations", &C::max_iterations, nonNegative(), "Levenberg–Marquardt iterations")
          .number("function_tolerance", &C::function_tolerance, nonNegative(),
                  "Stop when a step lowers the cost by less than this fraction")
          .number("gradient_tolerance", &C::gradient_tolerance, nonNegative(), "Ceres gradient tolerance")
          .number("parameter_tolerance", &C::parameter_tolerance, nonNegative(), "Ceres parameter tolerance")
          .integer("threads", &C::threads, atLeast(1), "Threads for residual and Jacobian evaluation")
          .flag("verbose", &C::verbose, "Ceres progress to stderr")
          .flag("gravity_prior", &C::gravity_prior,
                "SLAM runs: a gravity-direction (roll/pitch) prior on each keyframe with IMU gravity data (gravity.txt)")
          .number("gravity_sigma_deg", &C::gravity_sigma_deg, closed(0, 45),
                  "° per axis of the gravity priors; 0 = the σ stated with each measurement")
;
  return fields;
}

PoseGraphConfig loadPoseGraphConfig(const std::filesystem::path& yaml_file) {
  return configFromYaml(readTextFile(yaml_file), yaml_file.string(), "graph", PoseGraphConfig{});
}

}  // namespace hazmap
