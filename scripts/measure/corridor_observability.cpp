// What the data can tell about each worst-day corridor frame's increment along the corridor
// (docs/registration.md, "Observability, measured"): a measurement, not a check, so it lives here
// and not in the test suite. Run it with scripts/corridor_observability.sh.
//
// Per frame, against the map of the frames before it placed at their true poses: the plain-ICP
// Hessian along the axis at the true pose (rotation marginalised; its share of the strongest and
// the standard deviation it implies), whether plain ICP started 0.5, 1 and 2 m either way along the
// axis comes back within 5 cm (geometry), and whether the label search (placeAlongAxisByLabels)
// started 1 m either way puts it back within 5 cm (labels).
//
// With --targets it prints instead the issue-19 targets on the corridor that it does not meet
// (>= 98 % of the frames within 5 cm / 0.5 deg, none silently wrong), per row with and without
// wheel odometry: the statement of what is left, once a disabled test.
#include <Eigen/Eigenvalues>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>

#include "hazmap/core/error.hpp"
#include "hazmap/core/memory.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/odometry/local_map.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/registration/registration_target.hpp"
#include "hazmap/sim/simulator.hpp"
#include "odometry/odometry_checks.hpp"

namespace hazmap {
namespace {

constexpr double kDeg = M_PI / 180.0;

struct Options {
  unsigned seed = 1;
  std::size_t frames = 100;
  std::string out;  ///< CSV file; stdout when empty
  bool targets = false;
};

sim::Simulator worstDayCorridor(const Options& o) {
  sim::SimulatorConfig sc;
  sc.scenario = "corridor";
  sc.seed = o.seed;
  sc.max_frames = o.frames;
  return sim::Simulator(sim::SimulatorConfig::withPreset("worst-day", sc, "corridor_observability"));
}

/// One CSV row per frame after the first; the summary line goes to stderr.
std::string observabilityTable(const sim::Simulator& sim, unsigned seed) {
  const ClassTable& classes = sim.classTable();
  const OdometryConfig config = OdometryConfig::defaults();
  RegistrationConfig plain = config.registration;
  plain.use_classes = false;
  // The corridor's axis in the frame of the first scan (poses.txt's frame).
  const Eigen::Vector3d axis = sim.worldFromFirst().linear().transpose() * Eigen::Vector3d::UnitX();
  LocalMap map(config.map);
  std::vector<LabeledCloud> labels;
  std::ostringstream csv;
  csv << "frame,world_x,end_distance,slip,kick_deg,encoder_error,info_ratio,sigma_axis,geometry,labels,labels_precise,"
         "labelled_points,class\n";
  std::size_t counts[3] = {0, 0, 0};
  for (std::size_t i = 0; i < sim.frames(); ++i) {
    const LabeledCloud scan = sim.scan(i);
    const LabeledCloud prepared = preprocessForTracking(scan, config, classes);
    labels.push_back(labelledPointsOf(scan, config, classes));
    const Eigen::Isometry3d& truth = sim.groundTruth()[i];
    if (i > 0) {
      const RegistrationTarget target = map.makeTarget(classes, plain, /*lazy_normals=*/true);
      const RegistrationResult at = registerClouds(prepared, target, truth, classes, plain);
      // Information along the axis with the rotation free (Schur complement), as weakHorizontalAxis.
      const Matrix6d H = 0.5 * (at.hessian + at.hessian.transpose());
      const Eigen::Matrix3d S =
          H.topLeftCorner<3, 3>() - H.topRightCorner<3, 3>() * H.bottomRightCorner<3, 3>().ldlt().solve(H.bottomLeftCorner<3, 3>());
      const double along = axis.dot(S * axis);
      const double strongest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(S).eigenvalues()(2);
      const double sigma = at.residual_sigma / std::sqrt(std::max(along, 1e-12));
      bool geometry = true;
      for (const double d : {-2.0, -1.0, -0.5, 0.5, 1.0, 2.0}) {
        const RegistrationResult r = registerClouds(prepared, target, shiftedAlong(truth, axis, d), classes, plain);
        geometry = geometry && std::abs(axis.dot(r.transform.translation() - truth.translation())) <= 0.05;
        if (!geometry) break;
      }
      std::vector<std::pair<Eigen::Isometry3d, const LabeledCloud*>> placed;
      for (std::size_t j = 0; j < i; ++j)
        if ((sim.groundTruth()[j].translation() - truth.translation()).norm() <= kRecoveryMapRadius + config.label_axis.range)
          placed.push_back({sim.groundTruth()[j], &labels[j]});
      const LabeledCloud label_map = labelMapOf(placed, classes);
      bool by_labels = true, precise = true;
      std::size_t labelled = 0;
      for (const double d : {-1.0, 1.0}) {
        const LabelPlacement lp =
            placeAlongAxisByLabels({&labels[i], &label_map}, classes, shiftedAlong(truth, axis, d), axis, config);
        labelled = lp.labelled;
        by_labels = by_labels && lp.decided && std::abs(lp.offset + d) <= 0.05;
        precise = precise && lp.precise;
      }
      const Eigen::Isometry3d true_inc = sim.groundTruth()[i - 1].inverse() * truth;
      const Eigen::Isometry3d odo_inc = sim.odometry()[i - 1].inverse() * sim.odometry()[i];
      const double wx = sim.worldPoses()[i].translation().x();
      const int cls = geometry ? 0 : by_labels ? 1 : 2;
      ++counts[cls];
      char line[320];
      std::snprintf(line, sizeof line, "%zu,%.2f,%.2f,%d,%.1f,%.3f,%.4f,%.4f,%d,%d,%d,%zu,%s\n", i, wx,
                    std::min(wx, 60.0 - wx), int(sim.slips()[i]), sim.yawKicks()[i] / kDeg,
                    translationNorm(true_inc.inverse() * odo_inc), along / std::max(strongest, 1e-12), sigma,
                    int(geometry), int(by_labels), int(by_labels && precise), labelled,
                    cls == 0 ? "geometry" : cls == 1 ? "labels" : "none");
      csv << line;
    }
    map.integrate(prepared.transformed(truth), truth.translation(), classes);
  }
  std::fprintf(stderr, "corridor worst day seed %u: %zu frames determinable from geometry, %zu only from labels, %zu from neither\n",
               seed, counts[0], counts[1], counts[2]);
  return csv.str();
}

/// The corridor's row of the issue-19 targets, tracked as the WorstDay tests track (recovery on,
/// suspect frames re-examined): frames within 5 cm / 0.5 deg of their true increment and frames
/// off by more than 20 cm / 2 deg yet not flagged.
std::string targetsRow(const sim::Simulator& sim, bool wheel) {
  OdometryConfig config = OdometryConfig::defaults();
  config.recovery.relocalise = true;
  config.recovery.relocalise_suspect = true;
  Odometry odo(sim.classTable(), config);
  for (std::size_t i = 0; i < sim.frames(); ++i) {
    std::optional<Eigen::Isometry3d> inc;
    if (wheel && i > 0) inc = sim.odometry()[i - 1].inverse() * sim.odometry()[i];
    odo.addFrame(sim.scan(i), inc);
  }
  std::size_t frames = 0, within = 0, silently_wrong = 0;
  for (std::size_t i = 1; i < sim.frames(); ++i) {
    const OdometryFrame& f = odo.frames()[i];
    const Eigen::Isometry3d error = (sim.groundTruth()[i - 1].inverse() * sim.groundTruth()[i]).inverse() * f.increment;
    const double t = translationNorm(error), r = rotationAngle(error);
    ++frames;
    within += t <= 0.05 && r <= 0.5 * kDeg;
    silently_wrong += (t > 0.2 || r > 2 * kDeg) && !isFlagged(f.status);
  }
  char line[200];
  std::snprintf(line, sizeof line, "%s,%zu,%zu,%.3f,%zu\n", wheel ? "wheel" : "no-wheel", frames, within,
                frames ? double(within) / double(frames) : 0.0, silently_wrong);
  return line;
}

std::size_t count(const std::string& option, const std::string& text) {
  std::size_t used = 0;
  unsigned long v = 0;
  try {
    v = std::stoul(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size()) fail(option, "expected a whole number, got '" + text + "'");
  return v;
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) fail(a, "needs a value");
      return argv[++i];
    };
    if (a == "--seed") o.seed = static_cast<unsigned>(count(a, value()));
    else if (a == "--frames") o.frames = count(a, value());
    else if (a == "--out") o.out = value();
    else if (a == "--targets") o.targets = true;
    else fail(a, "unknown option (usage: corridor_observability [--seed N] [--frames N] [--targets] [--out FILE.csv])");
  }
  if (o.frames < 2) fail("--frames", "must be >= 2");
  return o;
}

int run(int argc, char** argv) {
  const Options o = parse(argc, argv);
  const sim::Simulator sim = worstDayCorridor(o);
  std::string csv;
  if (o.targets) csv = "odometry,frames,within,within_share,silently_wrong\n" + targetsRow(sim, true) + targetsRow(sim, false);
  else csv = observabilityTable(sim, o.seed);
  if (o.out.empty()) std::cout << csv;
  else writeTextAtomically(o.out, csv);
  return 0;
}

}  // namespace
}  // namespace hazmap

int main(int argc, char** argv) {
  hazmap::retainFreedMemory();  // registers scans in a loop (DEVELOPERS.md)
  try {
    return hazmap::run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "corridor_observability: " << e.what() << "\n";
    return 1;
  }
}
