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

const ConfigFields<RecoveryConfig>& configFields(ConfigTag<RecoveryConfig>) {
  using C = RecoveryConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Recovery when tracking fails: guess-free global registration, whole-map re-localisation, "
                      "lost frames re-estimated (thresholds: constants in src/odometry/odometry_checks.hpp).")
          .flag("relocalise", &C::relocalise,
                "Try a guess-free global registration when ICP from the guess fails (status relocalised when verified)")
          .flag("relocalise_suspect", &C::relocalise_suspect,
                "Also when ICP from the guess passed but is suspect (poor fit, far from the guess, a weak horizontal "
                "axis): slower, catches wrong-but-passing frames (a crawler's worst day); flags weak-axis frames")
          .number("max_translation", &C::max_translation, positive(),
                  "m; a recovered increment moving farther is implausible for the platform (rejected)")
          .number("max_rotation", &C::max_rotation, positive(),
                  "rad; a recovered increment turning more is implausible for the platform (rejected)")
          .flag("whole_map", &C::whole_map,
                "After whole_map_after consecutive fallback frames, register the scan globally against the keyframes "
                "(a kidnapped robot); verified by ICP, ambiguity refused, the local map rebuilt from the keyframes")
          .integer("whole_map_after", &C::whole_map_after, atLeast(1),
                   "Consecutive fallback frames before the whole map is tried")
          .number("keyframe_distance", &C::keyframe_distance, positive(),
                  "m; a verified frame this far from the last keyframe becomes one (whole-map re-localisation)")
          .number("keyframe_rotation", &C::keyframe_rotation, positive(), "rad; …or turned this much")
          .flag("reestimate_lost_frames", &C::reestimate_lost_frames,
                "Frame to map: a fallback frame's scan waits outside the local map; once a later frame is verified "
                "the waiting frames are re-registered against the recovered map from interpolated poses (verified: "
                "relocalised, the scan enters the map; else the interpolated pose is kept, flagged)")
          .integer("lost_frames_max", &C::lost_frames_max, atLeast(1),
                   "Frame to map: lost frames that wait at most; beyond, the oldest enters the map at its guessed pose");
  return fields;
}

const ConfigFields<LabelAxisConfig>& configFields(ConfigTag<LabelAxisConfig>) {
  using C = LabelAxisConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("With recovery.relocalise_suspect and property ICP: along a horizontal axis the geometry cannot "
                      "observe, the scan's labelled points decide the position (thresholds: constants in "
                      "src/odometry/odometry_checks.hpp).")
          .flag("search", &C::search, "Search the labels along the weak axis (else such a frame is flagged)")
          .number("range", &C::range, positive(), "m; the labels' search either way along the axis");
  return fields;
}

const ConfigFields<OdometryConfig>& configFields(ConfigTag<OdometryConfig>) {
  using C = OdometryConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Tracking: preprocessing, (property-)ICP against the previous scan or the local "
                      "map, failure detection; recovery and the label-axis search in their sections.")
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
          .number("fallback_sigma_translation", &C::fallback_sigma_translation, positive(),
                  "m; covariance of a fallback increment (and along degenerate directions)")
          .number("fallback_sigma_rotation", &C::fallback_sigma_rotation, positive(), "rad")
          .section("recovery", &C::recovery, "")
          .section("global_registration", &C::global,
                   "Recovery's global registration; use_classes applies only when registration.use_classes does")
          .section("label_axis", &C::label_axis, "")
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
