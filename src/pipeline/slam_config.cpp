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

// SlamConfig::honest_odometry_edges and its model's keys (issue 14, docs/pose_graph.md).
ConfigFields<SlamConfig>& honestEdgeFields(ConfigFields<SlamConfig>& f) {
  using C = SlamConfig;
  return f.flag("honest_odometry_edges", &C::honest_odometry_edges,
                "Frame-to-map odometry edges: additive floor + a wrong-basin term when the wheels or constant velocity contradict the increment")
          .number("odometry_floor_translation", &C::odometry_floor_translation, nonNegative(),
                  "m; honest_odometry_edges: added to the increment's covariance in every direction")
          .number("odometry_floor_rotation", &C::odometry_floor_rotation, nonNegative(), "rad; likewise")
          .number("odometry_turn_translation", &C::odometry_turn_translation, nonNegative(),
                  "m per rad of the frame's turn; honest_odometry_edges: σ added to x and y")
          .number("odometry_turn_rotation", &C::odometry_turn_rotation, nonNegative(),
                  "rad per rad of the frame's turn; honest_odometry_edges: σ added to yaw")
          .number("odometry_gate_probability", &C::odometry_gate_probability, Range{0.0, 1.0, true, true},
                  "honest_odometry_edges: χ²(3) quantile (x, y, yaw) beyond which a motion prior contradicts the increment")
          .number("wheel_gate_forward_fraction", &C::wheel_gate_forward_fraction, nonNegative(),
                  "Nominal wheel noise of the gate: forward σ = this × step + wheel_gate_forward_sigma")
          .number("wheel_gate_forward_sigma", &C::wheel_gate_forward_sigma, positive(), "m")
          .number("wheel_gate_lateral_sigma", &C::wheel_gate_lateral_sigma, positive(), "m; lateral σ")
          .number("wheel_gate_yaw_sigma", &C::wheel_gate_yaw_sigma, positive(),
                  "rad; yaw σ = this + wheel_gate_turn_fraction × |turn|")
          .number("wheel_gate_turn_fraction", &C::wheel_gate_turn_fraction, nonNegative(), "Yaw skid per rad of turn")
          .number("velocity_gate_translation_sigma", &C::velocity_gate_translation_sigma, positive(),
                  "m; how far an increment may differ from the previous one (x, y) without doubt")
          .number("velocity_gate_rotation_sigma", &C::velocity_gate_rotation_sigma, positive(), "rad; likewise in yaw")
          .flag("odometry_edge_mixture", &C::odometry_edge_mixture,
                "honest_odometry_edges: a doubtful edge is a max-mixture of its tight Gaussian and the wide wrong-basin one")
          .number("odometry_mixture_weight", &C::odometry_mixture_weight, Range{0.0, 1.0, true, true},
                  "Prior probability of a doubtful edge's wrong-basin component");
}

// The `slam:` section: settings of SlamConfig itself, grouped under one key.
const ConfigFields<SlamConfig>& slamSectionFields() {
  using C = SlamConfig;
  static const ConfigFields<C> fields =
      honestEdgeFields(ConfigFields<C>("Keyframes and the pose graph's odometry edges.")
          .number("keyframe_distance", &C::keyframe_distance, positive(),
                  "m of travel after which a frame becomes a loop-closure keyframe")
          .number("keyframe_angle", &C::keyframe_angle, positive(), "rad of turn, likewise")
          .flag("optimise_online", &C::optimise_online, "Re-optimise the graph whenever a loop is accepted")
          .integer("loop_search_every", &C::loop_search_every, atLeast(1),
                   "Search loops on every n-th keyframe (online cost; 1 = every keyframe)")
          .integer("loop_pause_after_accept", &C::loop_pause_after_accept, nonNegative(),
                   "Keyframes not searched for loops after one whose search accepted a loop")
          .flag("loops_beside_tracking", &C::loops_beside_tracking,
                "Run a keyframe's loop stage while the next scan is tracked (same results; not with reanchor_map)")
          .number("min_translation_sigma", &C::min_translation_sigma, positive(),
                  "m; floor on an ICP increment's standard deviation before inverting it")
          .number("min_rotation_sigma", &C::min_rotation_sigma, positive(), "rad")
          .flag("additive_floor", &C::additive_floor,
                "Floors added to the increment's covariance (every direction) instead of raising its diagonal")
          .number("label_only_sigma", &C::label_only_sigma, nonNegative(),
                  "m; added to an odometry edge along the directions only labelled patches fixed (0 = off)")
          .number("odometry_covariance_scale", &C::odometry_covariance_scale, positive(),
                  "Calibration: odometry-edge covariance = this × the floored ICP covariance (fitted by NEES)")
          .number("motion_disagreement_weight", &C::motion_disagreement_weight, nonNegative(),
                  "Calibration: adds (weight × the increment's departure from constant velocity)² to its variance"))
          .number("anchor_radius", &C::anchor_radius, nonNegative(),
                  "m; frame-to-map: edge from each keyframe to the nearest older keyframe within this (0 = off)")
          .number("anchor_sigma_translation", &C::anchor_sigma_translation, positive(),
                  "m; added to a map-anchor edge's ICP covariance (calibrated by NEES)")
          .number("anchor_sigma_rotation", &C::anchor_sigma_rotation, positive(), "rad; likewise")
          .flag("stalled_edges_use_wheel_noise", &C::stalled_edges_use_wheel_noise,
                "Odometry edge of a frame whose ICP stopped at its iteration limit: wheel-odometry covariance")
          .flag("anchors_carry_unverified_steps", &C::anchors_carry_unverified_steps,
                "A map anchor's covariance includes the unverified (fallback, stalled) increments it spans")
          .flag("anchors_share_drift", &C::anchors_share_drift,
                "Each anchor's chained guess covariance times the number of anchors whose spans overlap it")
          .flag("anchors_carry_guess_directions", &C::anchors_carry_guess_directions,
                "A map anchor's covariance includes the chained covariance of the directions where tracking kept the guess")
          .flag("final_accept_test", &C::final_accept_test,
                "Keep the optimised trajectory only when its keyframe map is as crisp (mean map entropy) as tracking's")
          .number("map_entropy_radius", &C::map_entropy_radius, positive(),
                  "m; neighbourhood of the final accept test's mean map entropy")
          .flag("reanchor_map", &C::reanchor_map,
                "Frame-to-map: after each applied optimisation the tracker's local map follows the optimised poses")
          .number("reanchor_min_shift", &C::reanchor_min_shift, nonNegative(),
                  "m; re-anchor only when the optimisation moved some frame by more than this")
          .flag("loop_bias", &C::loop_bias,
                "Loops within loop_bias_window keyframes at both ends share one bias node (their common error counted once)")
          .integer("loop_bias_window", &C::loop_bias_window, nonNegative(),
                   "keyframes; loop_bias: a loop joins a group whose first loop is this close at both ends")
          .number("loop_own_sigma_translation", &C::loop_own_sigma_translation, positive(),
                  "m; loop_bias: added to each loop's own covariance instead of the verification floor")
          .number("loop_own_sigma_rotation", &C::loop_own_sigma_rotation, positive(), "rad; likewise")
          .number("loop_shared_sigma_translation", &C::loop_shared_sigma_translation, positive(),
                  "m; loop_bias: prior σ of a group's shared error")
          .number("loop_shared_sigma_rotation", &C::loop_shared_sigma_rotation, positive(), "rad; likewise")
          .number("loop_tail_weight", &C::loop_tail_weight, Range{0.0, 1.0, false, true},
                  "loop_bias: prior weight of a loop's tail component (a max-mixture edge; 0 = one Gaussian)")
          .number("loop_tail_sigma_translation", &C::loop_tail_sigma_translation, positive(),
                  "m; loop_bias: σ the tail component adds to the loop's own covariance")
          .number("loop_tail_sigma_rotation", &C::loop_tail_sigma_rotation, positive(), "rad; likewise")
          .flag("innovation_gate", &C::innovation_gate,
                "Gate loops by the χ² test against the graph's own relative-pose covariance (else the drift model)")
          .flag("submaps_only_frame_to_map", &C::submaps_only_frame_to_map,
                "Verify loops against submaps only when tracking is frame-to-map (frame-to-frame: scan to scan)")
          .flag("misfit_only_frame_to_map", &C::misfit_only_frame_to_map,
                "The loop covariance's misfit term (verification.misfit_scale) only when tracking is frame-to-map")
          .flag("nearest_partial_loops_only_frame_to_map", &C::nearest_partial_loops_only_frame_to_map,
                "Camera-label loops at the matched stretch's nearest keyframe (loop_closure.partial_nearest_keyframe) only when tracking is frame-to-map");
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

void SlamConfig::applyYamlString(const std::string& yaml, const std::string& where) {
  *this = readConfig(parseConfigYaml(yaml, where), ConfigPlace{where, ""}, *this);
}

void SlamConfig::applyYamlFile(const std::filesystem::path& path) {
  applyYamlString(readTextFile(path), path.string());
}

void SlamConfig::applySetting(const std::string& assignment) { applyConfigSetting(*this, assignment); }

void SlamConfig::validate() const { validateConfig(*this, ""); }

}  // namespace hazmap
