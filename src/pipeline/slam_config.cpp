// SlamConfig: the run's YAML (every stage's section) through the field tables of
// core/config_fields.hpp — one parse from the file to the ICP.
#include "hazmap/core/config_fields.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/pipeline/slam.hpp"

namespace hazmap {

const ConfigFields<WheelOdometryNoise>& configFields(ConfigTag<WheelOdometryNoise>) {
  using C = WheelOdometryNoise;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Uncertainty of a wheel-odometry increment (odometry edges of frames where ICP failed).")
          .number("translation_sigma", &C::translation_sigma, positive(), "m, x and y")
          .number("vertical_sigma", &C::vertical_sigma, positive(), "m, z")
          .number("yaw_sigma", &C::yaw_sigma, positive(), "rad")
          .number("tilt_sigma", &C::tilt_sigma, positive(), "rad, roll and pitch");
  return fields;
}

namespace {

// The `slam:` section: settings of SlamConfig itself, grouped under one key.
const ConfigFields<SlamConfig>& slamSectionFields() {
  using C = SlamConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Keyframes and the pose graph's odometry edges.")
          .number("keyframe_distance", &C::keyframe_distance, positive(),
                  "m of travel after which a frame becomes a loop-closure keyframe")
          .number("keyframe_angle", &C::keyframe_angle, positive(), "rad of turn, likewise")
          .flag("optimise_online", &C::optimise_online,
                "Re-optimise the graph whenever a loop is accepted (beyond 4,000 frames, the loops of "
                "every ⌈frames / 4,000⌉ keyframes together)")
          .integer("loop_search_every", &C::loop_search_every, atLeast(1),
                   "Search loops on every n-th keyframe (online cost; 1 = every keyframe)")
          .integer("loop_pause_after_accept", &C::loop_pause_after_accept, nonNegative(),
                   "Keyframes not searched for loops after one whose search accepted a loop")
          .integer("online_keyframe_graph_after", &C::online_keyframe_graph_after, nonNegative(),
                   "Frames beyond which the online solves are of the keyframes' graph (the chains between "
                   "keyframes folded; the end solves the whole graph); 0 = always the whole graph")
          .choice("back_end", &C::back_end,
                  {{"beside-tracking", BackEndSchedule::BesideTracking},
                   {"own-thread", BackEndSchedule::OwnThread},
                   {"after-frame", BackEndSchedule::AfterFrame}},
                  "When a keyframe's loop stage runs: beside the next scan's tracking, on a thread of its own "
                  "(tracking never waits; hazmap live's default), or before the next scan (same final results)")
          .number("back_end_queue_mb", &C::back_end_queue_mb, positive(),
                  "MiB; with back_end own-thread: keyframe scans waiting for the back end, at most (then tracking waits)")
          .number("min_translation_sigma", &C::min_translation_sigma, positive(),
                  "m; floor on an ICP increment's standard deviation before inverting it")
          .number("min_rotation_sigma", &C::min_rotation_sigma, positive(), "rad")
          .number("anchor_radius", &C::anchor_radius, nonNegative(),
                  "m; frame-to-map: edge from each keyframe to the nearest older keyframe within this (0 = off)")
          .number("anchor_sigma_translation", &C::anchor_sigma_translation, positive(),
                  "m; added to a map-anchor edge's ICP covariance (calibrated by NEES)")
          .number("anchor_sigma_rotation", &C::anchor_sigma_rotation, positive(), "rad; likewise")
          .flag("innovation_gate", &C::innovation_gate,
                "Gate loops by the χ² test against the graph's own relative-pose covariance (else the drift model)");

  return fields;
}

}  // namespace

const ConfigFields<SlamConfig>& configFields(ConfigTag<SlamConfig>) {
  using C = SlamConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("A whole run (hazmap run --config, hazmap demo): every stage's section.")
          .section("odometry", &C::odometry, "")
          .section("property_icp", &C::property_icp, "")
          .section("loop_closure", &C::loop_closure, "PGO methods only")
          .section("graph", &C::graph, "")
          .section("wheel_noise", &C::wheel_noise, "")
          .section<SlamConfig>("slam", [](C& c) -> C& { return c; }, slamSectionFields(),
                               "Settings of the run itself");
  return fields;
}

Matrix6d WheelOdometryNoise::information() const {
  Vector6d sigma;
  sigma << translation_sigma, translation_sigma, vertical_sigma, tilt_sigma, tilt_sigma, yaw_sigma;
  return sigma.cwiseProduct(sigma).cwiseInverse().asDiagonal();
}

SlamConfig SlamConfig::forMethod(SlamMethod method) {
  SlamConfig c;
  c.method = method;
  c.odometry.registration.use_classes = usesClasses(method);
  c.loop_closure.method =
      usesClasses(method) ? CandidateMethod::Constellation : CandidateMethod::Distance;
  return c;
}

void SlamConfig::applyYamlString(const std::string& yaml, const std::string& where) {
  *this = readConfig(parseConfigYaml(yaml, where), ConfigPlace{where, ""}, *this);
}

void SlamConfig::applyYamlFile(const std::filesystem::path& path) {
  applyYamlString(readTextFile(path), path.string());
}

void SlamConfig::applySetting(const std::string& assignment) { applyConfigSetting(*this, assignment); }

void SlamConfig::validate() const { validateConfig(*this, ""); }

}  // namespace hazmap
