// OdometryConfig and LocalMapConfig: their field tables (core/config_fields.hpp) and the
// YAML entry points derived from them.
#include "hazmap/core/config_fields.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/odometry/odometry.hpp"

namespace hazmap {

const ConfigFields<LocalMapConfig>& configFields(ConfigTag<LocalMapConfig>) {
  using C = LocalMapConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Frame-to-map tracking: the bounded local voxel map that keeps classes.")
          .number("voxel_size", &C::voxel_size, positive(), "m; voxel edge of the local map")
          .integer("max_points_per_voxel", &C::max_points_per_voxel, atLeast(1), "Points kept per voxel")
          .number("min_point_distance", &C::min_point_distance, nonNegative(),
                  "m; a point this close to one already in its voxel is not added (0 = off)")
          .number("max_distance", &C::max_distance, positive(),
                  "m; voxels farther from the robot are dropped")
          .integer("normal_updates", &C::normal_updates, closed(0, 255),
                   "Cap on re-estimating one map point's normal (0 = exact: whenever its "
                   "neighbourhood changed)");
  return fields;
}

// Whole-map re-localisation and what enters the local map (issue 19).
static ConfigFields<OdometryConfig>& addWholeMapFields(ConfigFields<OdometryConfig>& fields) {
  using C = OdometryConfig;
  return fields
          .flag("whole_map_relocalise", &C::whole_map_relocalise,
                "After whole_map_after consecutive fallback frames, register the scan globally against the keyframes "
                "(a kidnapped robot); verified by ICP, ambiguity refused, the local map rebuilt from the keyframes")
          .integer("whole_map_after", &C::whole_map_after, atLeast(1),
                   "Consecutive fallback frames before the whole map is tried")
          .number("keyframe_distance", &C::keyframe_distance, positive(),
                  "m; a verified frame this far from the last keyframe becomes one (whole-map re-localisation)")
          .number("keyframe_rotation", &C::keyframe_rotation, positive(), "rad; …or turned this much")
          .number("whole_map_min_fit", &C::whole_map_min_fit, closed(0, 1),
                  "A whole-map answer must put this share of the source points on a keyframe surface")
          .flag("whole_map_confirm", &C::whole_map_confirm,
                "A whole-map answer is used only when the next frame's agrees with it (a plausible motion apart)")
          .flag("reestimate_lost_frames", &C::reestimate_lost_frames,
                "Frame to map: a fallback frame's scan waits outside the local map; once a later frame is verified "
                "the waiting frames are re-registered against the recovered map from interpolated poses (verified: "
                "relocalised, the scan enters the map; else the interpolated pose is kept, flagged)")
          .integer("lost_frames_max", &C::lost_frames_max, atLeast(1),
                   "Frame to map: lost frames that wait at most; beyond, the oldest enters the map at its guessed pose")
          .flag("flag_weak_axis", &C::flag_weak_axis,
                "With relocalise_suspect: a frame weakly constrained along a horizontal axis is flagged "
                "(degenerate), not tracked")
          .number("flag_weak_axis_ratio", &C::flag_weak_axis_ratio, closed(0, 1),
                  "With flag_weak_axis: the weak-axis ratio (as suspect_weak_axis_ratio) below which a frame is flagged")
          .number("flag_correction_after_flagged", &C::flag_correction_after_flagged, nonNegative(),
                  "m; with relocalise_suspect: a frame after a flagged one whose answer lies farther than this from "
                  "the guess along that frame's weakest horizontal axis is flagged (0 = off)")
          .flag("label_axis_search", &C::label_axis_search,
                "With relocalise_suspect and property ICP: along a horizontal axis the geometry cannot observe, the "
                "scan's labelled points decide the position (else the frame is flagged)")
          .number("label_axis_range", &C::label_axis_range, positive(), "m; the labels' search either way along the axis")
          .number("label_axis_gate", &C::label_axis_gate, positive(),
                  "m; a labelled pair within this (cost, with the mismatch penalty) scores")
          .number("label_axis_min_support", &C::label_axis_min_support, nonNegative(),
                  "Label score the best position needs (about that many well-matched labelled points)")
          .number("label_axis_ambiguity", &C::label_axis_ambiguity, closed(0, 1),
                  "A position label_axis_gate or more from the best scoring this x as much: undecided, flagged")
          .number("label_axis_sigma", &C::label_axis_sigma, positive(),
                  "m; standard deviation added along the axis when labels placed the frame")
          .number("label_axis_voxel", &C::label_axis_voxel, positive(), "m; the labelled points' resolution for the search")
          .number("label_axis_confirm", &C::label_axis_confirm, nonNegative(),
                  "m; labels placing the frame within this of ICP's answer confirm it (ICP's answer kept)")
          .number("label_axis_context", &C::label_axis_context, positive(),
                  "m; unlabelled returns this close to labelled ones take part (a mismatch costs the class penalty)")
          .number("label_axis_consistency", &C::label_axis_consistency, positive(),
                  "m; the halves of the labelled points place the frame this close, or it stays flagged");
}

const ConfigFields<OdometryConfig>& configFields(ConfigTag<OdometryConfig>) {
  using C = OdometryConfig;
  static const ConfigFields<C> fields =
      addWholeMapFields(ConfigFields<C>("Tracking: preprocessing, (property-)ICP against the previous scan or the local "
                      "map, failure detection.")
          .choice("mode", &C::mode, {{"map", OdometryMode::FrameToMap}, {"frame", OdometryMode::FrameToFrame}},
                  "map: scan to local map; frame: scan to previous scan (the paper)")
          .section("registration", &C::registration, "The tracking ICP")
          .number("min_range", &C::min_range, nonNegative(), "m; closer points are dropped (the robot's body)")
          .number("max_range", &C::max_range, positive(), "m; farther points are dropped")
          .number("voxel_size", &C::voxel_size, positive(),
                  "m; the scan as it enters the map / the next frame's target")
          .number("source_voxel_size", &C::source_voxel_size, nonNegative(),
                  "m; the scan registered (0 = voxel_size)")
          .section("map", &C::map, "The local map (mode map)")
          .number("min_fitness", &C::min_fitness, closed(0, 1),
                  "Fraction of source points with a partner below which the frame falls back to the guess")
          .number("max_correction_translation", &C::max_correction_translation, positive(),
                  "m; ICP farther from the guess = diverged")
          .number("max_correction_rotation", &C::max_correction_rotation, positive(), "rad")
          .flag("keep_guess_along_degenerate", &C::keep_guess_along_degenerate,
                "Replace ICP's degenerate directions by the guess")
          .number("fallback_sigma_translation", &C::fallback_sigma_translation, positive(),
                  "m; covariance of a fallback increment (and along degenerate directions)")
          .number("fallback_sigma_rotation", &C::fallback_sigma_rotation, positive(), "rad")
          .flag("relocalise", &C::relocalise,
                "Try a guess-free global registration when ICP from the guess fails or is suspect "
                "(status relocalised when verified)")
          .flag("relocalise_suspect", &C::relocalise_suspect,
                "Also when ICP from the guess passed but is suspect (poor fit, far from the guess): slower, "
                "catches wrong-but-passing frames (a crawler's worst day)")
          .number("suspect_fitness", &C::suspect_fitness, closed(0, 1),
                  "ICP from the guess passed but fits worse than this: try global registration too")
          .number("suspect_correction_translation", &C::suspect_correction_translation, positive(),
                  "m; ICP corrected the guess by more: try global registration too")
          .number("suspect_correction_rotation", &C::suspect_correction_rotation, positive(), "rad")
          .number("suspect_weak_axis_ratio", &C::suspect_weak_axis_ratio, closed(0, 1),
                  "ICP's weakest horizontal translation (Hessian eigenvalue, rotation marginalised) below this x the "
                  "strongest: suspect, and recovery also starts along that axis")
          .number("relocalise_axis_step", &C::relocalise_axis_step, positive(),
                  "m; recovery starts at +-1 and +-2 steps along a weak axis")
          .number("relocalise_probe_gain", &C::relocalise_probe_gain, closed(0, 1),
                  "A weak-axis probe's answer is used only when it fits better than the other answers by this much "
                  "(surface fit; 1 = never)")
          .number("relocalise_start_correction", &C::relocalise_start_correction, positive(),
                  "m; ICP from a recovery start other than the guess may end this far from it")
          .number("relocalise_start_correction_rotation", &C::relocalise_start_correction_rotation, positive(),
                  "rad; …and turn this much")
          .number("relocalise_min_gain", &C::relocalise_min_gain, closed(0, 1),
                  "A recovered answer replaces ICP from the guess (or, when that failed, the guess) only when it "
                  "fits better by this much (share of source points on a target surface)")
          .number("relocalise_inlier_distance", &C::relocalise_inlier_distance, positive(),
                  "m; a source point this close to a target surface (along its normal) fits, when recovery scores answers")
          .number("relocalise_max_translation", &C::relocalise_max_translation, positive(),
                  "m; a recovered increment moving farther is implausible (rejected)")
          .number("relocalise_max_rotation", &C::relocalise_max_rotation, positive(),
                  "rad; a recovered increment turning more is implausible (rejected)")
          .number("relocalise_distinct_translation", &C::relocalise_distinct_translation, positive(),
                  "m; verified answers farther apart are distinct…")
          .number("relocalise_distinct_rotation", &C::relocalise_distinct_rotation, positive(),
                  "rad; …or turned more than this")
          .number("relocalise_ambiguity", &C::relocalise_ambiguity, closed(0, 1),
                  "A distinct verified answer within this surface fit of the best: ambiguous, the frame is flagged")
          .number("relocalise_max_rmse_ratio", &C::relocalise_max_rmse_ratio, atLeast(1),
                  "A recovered answer fitting with an inlier RMSE above this × that of tracked frames is rejected")
          .number("relocalise_map_radius", &C::relocalise_map_radius, positive(),
                  "m; the global registration's target is the local map within this radius of the previous pose"))
          .section("motion_hypotheses", &C::motion_hypotheses,
                   "The guess after a sudden turn: motion hypotheses scored cheaply before ICP")
          .section("global_registration", &C::global,
                   "Used when relocalise triggers; use_classes applies only when registration.use_classes does")
          .rule("max_range", [](const C& c) { return c.max_range > c.min_range; }, "must be > min_range");
  return fields;
}

void LocalMapConfig::validate() const { validateConfig(*this, "odometry.map"); }
void OdometryConfig::validate() const { validateConfig(*this, "odometry"); }
OdometryConfig OdometryConfig::defaults() { return OdometryConfig{}; }

OdometryConfig odometryConfigFromYaml(const std::string& yaml, const std::string& where,
                                      const OdometryConfig& base) {
  return configFromYaml(yaml, where, "odometry", base);
}

OdometryConfig loadOdometryConfig(const std::string& path, const OdometryConfig& base) {
  return odometryConfigFromYaml(readTextFile(path), path, base);
}

}  // namespace hazmap
