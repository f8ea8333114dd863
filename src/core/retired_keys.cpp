// Keys that are no longer keys (issue 37). A YAML file or `--set` naming one gets the usual
// unknown-key error plus what became of it, so a user's old config explains itself:
//  - an experiment measured and not adopted: the code is gone, its dated write-up is in
//    docs/history/ (the row names it);
//  - an internal threshold that became a named constant in the file that uses it (issue 37
//    part two: every key is a default path or a user's choice; the row names the file);
//  - a key that moved: the row names its new path.
#include "hazmap/core/retired_keys.hpp"

#include <string_view>
#include <utility>

namespace hazmap::config_detail {

namespace {

constexpr std::string_view kNotAdopted = "measured and not adopted";
constexpr std::string_view kAlwaysOn = "the switch of an adopted measure, now always on";
constexpr std::string_view kAlwaysOnHere = "the switch of an adopted measure, now always on in ";

enum class Fate { Retired, Constant, Moved };

struct RetiredKey {
  std::string_view path;     ///< dotted, from the run config's top (`hazmap run --set` spelling)
  std::string_view history;  ///< the write-up (Retired), the file holding the constant (Constant),
                             ///< or the new dotted path (Moved), relative to the repository / run config
  std::string_view why = kNotAdopted;
  Fate fate = Fate::Retired;
};

/// A key that is now a named constant in `file`.
constexpr RetiredKey constant(std::string_view path, std::string_view file) { return {path, file, {}, Fate::Constant}; }
/// A key now spelled `to`.
constexpr RetiredKey moved(std::string_view path, std::string_view to) { return {path, to, {}, Fate::Moved}; }

/// Whole sections whose keys moved: every key under `from` (but the section's own, which are
/// known and never reach here) is now the same key under `to`.
struct MovedSection {
  std::string_view from, to, why;
};

constexpr MovedSection kMovedSections[] = {
    {"loop_closure.verification.registration", "odometry.registration",
     "loop verification runs tracking's ICP and states only its overrides"},
    {"odometry.global_registration.refinement", "odometry.registration",
     "the refinement runs tracking's ICP and states only its overrides"},
};

constexpr RetiredKey kRetiredKeys[] = {
    {"odometry.degenerate_in_sensor_frame", "docs/history/odometry-sensor-frame-and-slip-guess.md"},
    {"odometry.slip_guess_translation", "docs/history/odometry-sensor-frame-and-slip-guess.md"},
    {"odometry.slip_guess_yaw", "docs/history/odometry-sensor-frame-and-slip-guess.md"},
    {"odometry.map_skips_fallback", "docs/history/odometry-map-skips.md"},
    {"odometry.map_skips_flagged", "docs/history/odometry-map-skips.md"},
    {"loop_closure.near_duplicate_keyframes", "docs/history/loop-near-duplicates.md"},
    {"loop_closure.verification.coarse_degeneracy_scale", "docs/history/loop-verification-shortcuts.md"},
    {"loop_closure.verification.probe_source_points", "docs/history/loop-verification-shortcuts.md"},
    {"slam.honest_odometry_edges", "docs/history/honest-odometry-edges.md"},
    {"slam.odometry_floor_translation", "docs/history/honest-odometry-edges.md"},
    {"slam.odometry_floor_rotation", "docs/history/honest-odometry-edges.md"},
    {"slam.odometry_turn_translation", "docs/history/honest-odometry-edges.md"},
    {"slam.odometry_turn_rotation", "docs/history/honest-odometry-edges.md"},
    {"slam.odometry_gate_probability", "docs/history/honest-odometry-edges.md"},
    {"slam.wheel_gate_forward_fraction", "docs/history/honest-odometry-edges.md"},
    {"slam.wheel_gate_forward_sigma", "docs/history/honest-odometry-edges.md"},
    {"slam.wheel_gate_lateral_sigma", "docs/history/honest-odometry-edges.md"},
    {"slam.wheel_gate_yaw_sigma", "docs/history/honest-odometry-edges.md"},
    {"slam.wheel_gate_turn_fraction", "docs/history/honest-odometry-edges.md"},
    {"slam.velocity_gate_translation_sigma", "docs/history/honest-odometry-edges.md"},
    {"slam.velocity_gate_rotation_sigma", "docs/history/honest-odometry-edges.md"},
    {"slam.odometry_edge_mixture", "docs/history/max-mixture-odometry-edges.md"},
    {"slam.odometry_mixture_weight", "docs/history/max-mixture-odometry-edges.md"},
    {"slam.loop_bias", "docs/history/loop-bias-nodes.md"},
    {"slam.loop_bias_window", "docs/history/loop-bias-nodes.md"},
    {"slam.loop_own_sigma_translation", "docs/history/loop-bias-nodes.md"},
    {"slam.loop_own_sigma_rotation", "docs/history/loop-bias-nodes.md"},
    {"slam.loop_shared_sigma_translation", "docs/history/loop-bias-nodes.md"},
    {"slam.loop_shared_sigma_rotation", "docs/history/loop-bias-nodes.md"},
    {"slam.loop_tail_weight", "docs/history/loop-bias-nodes.md"},
    {"slam.loop_tail_sigma_translation", "docs/history/loop-bias-nodes.md"},
    {"slam.loop_tail_sigma_rotation", "docs/history/loop-bias-nodes.md"},
    {"slam.final_accept_test", "docs/history/back-end-switches.md"},
    {"slam.map_entropy_radius", "docs/history/back-end-switches.md"},
    {"slam.reanchor_map", "docs/history/back-end-switches.md"},
    {"slam.reanchor_min_shift", "docs/history/back-end-switches.md"},
    {"slam.additive_floor", "docs/history/back-end-switches.md"},
    {"slam.stalled_edges_use_wheel_noise", "docs/history/back-end-switches.md"},
    {"slam.anchors_carry_unverified_steps", "docs/history/back-end-switches.md"},
    {"slam.label_only_sigma", "docs/history/back-end-switches.md"},
    {"slam.odometry_covariance_scale", "docs/history/back-end-switches.md"},
    {"slam.motion_disagreement_weight", "docs/history/back-end-switches.md"},
    {"slam.anchors_carry_guess_directions", "docs/history/back-end-switches.md", kAlwaysOn},
    {"slam.anchors_share_drift", "docs/history/back-end-switches.md", kAlwaysOn},
    {"slam.submaps_only_frame_to_map", "docs/history/back-end-switches.md", kAlwaysOn},
    {"slam.misfit_only_frame_to_map", "docs/history/back-end-switches.md", kAlwaysOn},
    {"slam.nearest_partial_loops_only_frame_to_map", "docs/history/back-end-switches.md", kAlwaysOn},
    // Issue 37 part two: internal thresholds became named constants in the file that uses them,
    // switches of adopted measures became the code, and the tracking config was split.
    constant("odometry.suspect_fitness", "src/odometry/odometry_checks.hpp"),
    constant("odometry.suspect_correction_translation", "src/odometry/odometry_checks.hpp"),
    constant("odometry.suspect_correction_rotation", "src/odometry/odometry_checks.hpp"),
    constant("odometry.suspect_weak_axis_ratio", "src/odometry/odometry_checks.hpp"),
    constant("odometry.relocalise_axis_step", "src/odometry/odometry_checks.hpp"),
    constant("odometry.relocalise_probe_gain", "src/odometry/odometry_checks.hpp"),
    constant("odometry.relocalise_start_correction", "src/odometry/odometry_checks.hpp"),
    constant("odometry.relocalise_start_correction_rotation", "src/odometry/odometry_checks.hpp"),
    constant("odometry.relocalise_min_gain", "src/odometry/odometry_checks.hpp"),
    constant("odometry.relocalise_inlier_distance", "src/odometry/odometry_checks.hpp"),
    constant("odometry.relocalise_distinct_translation", "src/odometry/odometry_checks.hpp"),
    constant("odometry.relocalise_distinct_rotation", "src/odometry/odometry_checks.hpp"),
    constant("odometry.relocalise_ambiguity", "src/odometry/odometry_checks.hpp"),
    constant("odometry.relocalise_max_rmse_ratio", "src/odometry/odometry_checks.hpp"),
    constant("odometry.relocalise_map_radius", "src/odometry/odometry_checks.hpp"),
    constant("odometry.whole_map_min_fit", "src/odometry/odometry_checks.hpp"),
    constant("odometry.flag_weak_axis_ratio", "src/odometry/odometry_checks.hpp"),
    constant("odometry.flag_correction_after_flagged", "src/odometry/odometry_checks.hpp"),
    constant("odometry.label_axis_gate", "src/odometry/odometry_checks.hpp"),
    constant("odometry.label_axis_min_support", "src/odometry/odometry_checks.hpp"),
    constant("odometry.label_axis_ambiguity", "src/odometry/odometry_checks.hpp"),
    constant("odometry.label_axis_sigma", "src/odometry/odometry_checks.hpp"),
    constant("odometry.label_axis_voxel", "src/odometry/odometry_checks.hpp"),
    constant("odometry.label_axis_confirm", "src/odometry/odometry_checks.hpp"),
    constant("odometry.label_axis_context", "src/odometry/odometry_checks.hpp"),
    constant("odometry.label_axis_consistency", "src/odometry/odometry_checks.hpp"),
    {"odometry.whole_map_confirm", "src/odometry/odometry_whole_map.cpp", kAlwaysOnHere, Fate::Constant},
    {"odometry.flag_weak_axis", "src/odometry/frame_judgement.cpp", kAlwaysOnHere, Fate::Constant},
    {"odometry.keep_guess_along_degenerate", "src/odometry/frame_judgement.cpp", kAlwaysOnHere, Fate::Constant},
    moved("odometry.relocalise", "odometry.recovery.relocalise"),
    moved("odometry.relocalise_suspect", "odometry.recovery.relocalise_suspect"),
    moved("odometry.relocalise_max_translation", "odometry.recovery.max_translation"),
    moved("odometry.relocalise_max_rotation", "odometry.recovery.max_rotation"),
    moved("odometry.whole_map_relocalise", "odometry.recovery.whole_map"),
    moved("odometry.whole_map_after", "odometry.recovery.whole_map_after"),
    moved("odometry.keyframe_distance", "odometry.recovery.keyframe_distance"),
    moved("odometry.keyframe_rotation", "odometry.recovery.keyframe_rotation"),
    moved("odometry.reestimate_lost_frames", "odometry.recovery.reestimate_lost_frames"),
    moved("odometry.lost_frames_max", "odometry.recovery.lost_frames_max"),
    moved("odometry.label_axis_search", "odometry.label_axis.search"),
    moved("odometry.label_axis_range", "odometry.label_axis.range"),
    constant("odometry.global_registration.max_feature_neighbors", "src/registration/global_features.cpp"),
    constant("odometry.global_registration.max_source_features", "src/registration/global_registration.cpp"),
    constant("odometry.global_registration.mutual_filter", "src/registration/global_registration.cpp"),
    constant("odometry.global_registration.min_correspondences", "src/registration/global_registration.cpp"),
    constant("odometry.global_registration.edge_length_similarity", "src/registration/global_hypotheses.cpp"),
    constant("odometry.global_registration.label_score_share", "src/registration/global_registration.cpp"),
    constant("odometry.global_registration.min_labelled_points", "src/registration/global_registration.cpp"),
    constant("odometry.global_registration.min_label_agreement", "src/registration/global_registration.cpp"),
    constant("odometry.global_registration.landmark_cluster_distance", "src/registration/global_landmarks.cpp"),
    constant("odometry.global_registration.landmark_min_points", "src/registration/global_landmarks.cpp"),
    constant("odometry.global_registration.min_points", "src/registration/global_registration.cpp"),
    constant("odometry.global_registration.min_features", "src/registration/global_registration.cpp"),
    constant("odometry.global_registration.ambiguity_ratio", "src/registration/global_registration.cpp"),
    constant("odometry.global_registration.distinct_translation", "src/registration/global_hypotheses.cpp"),
    constant("odometry.global_registration.distinct_rotation_deg", "src/registration/global_hypotheses.cpp"),
    constant("odometry.global_registration.reject_degenerate", "src/registration/global_registration.cpp"),
    constant("odometry.global_registration.candidates_refined", "src/registration/global_registration.cpp"),
    constant("loop_closure.candidates.constellation.distance_tolerance", "src/loop/candidates.cpp"),
    constant("loop_closure.candidates.constellation.min_triangle_height", "src/loop/candidates.cpp"),
    constant("loop_closure.candidates.constellation.max_extent_ratio", "src/loop/candidates.cpp"),
    constant("loop_closure.candidates.constellation.max_hypotheses", "src/loop/candidates.cpp"),
    constant("loop_closure.candidates.constellation.visibility_range", "src/loop/candidates.cpp"),
    constant("loop_closure.candidates.constellation.miss_penalty", "src/loop/candidates.cpp"),
    constant("loop_closure.candidates.constellation.min_overlap", "src/loop/candidates.cpp"),
    constant("loop_closure.candidates.constellation.min_pair_distance", "include/hazmap/loop/candidates.hpp"),
    constant("loop_closure.consistency.translation_sigma_floor", "src/loop/consistency.cpp"),
    constant("loop_closure.consistency.rotation_sigma_floor", "src/loop/consistency.cpp"),
    {"loop_closure.consistency.use_drift_gate", "src/loop/loop_detector.cpp", kAlwaysOnHere, Fate::Constant},
    {"loop_closure.consistency.use_pairwise", "src/loop/loop_detector.cpp", kAlwaysOnHere, Fate::Constant},
    constant("loop_closure.verification.max_translation_sigma", "src/loop/verification.cpp"),
    constant("loop_closure.verification.max_rotation_sigma", "src/loop/verification.cpp"),
    constant("loop_closure.verification.min_translation_sigma", "src/loop/verification.cpp"),
    constant("loop_closure.verification.min_rotation_sigma", "src/loop/verification.cpp"),
    constant("loop_closure.verification.max_probe_spread", "src/loop/verify_icp.cpp"),
    constant("loop_closure.verification.guess_fitness_margin", "src/loop/verify_icp.cpp"),
    constant("graph.gravity_sigma_scale_frame_to_map", "src/pipeline/back_end.cpp"),
    constant("graph.gravity_alone_frame_to_map", "src/pipeline/back_end.cpp"),
};

// Whether the shorter of two dotted paths is a trailing part of the longer one: a command that
// reads one section (`hazmap odometry --set slip_guess_yaw=…`) names its keys without the prefix.
bool sameTail(std::string_view a, std::string_view b) {
  if (a.size() < b.size()) std::swap(a, b);
  if (!a.ends_with(b)) return false;
  return a.size() == b.size() || a[a.size() - b.size() - 1] == '.';
}

}  // namespace

std::string retiredKeyNote(const std::string& path) {
  for (const RetiredKey& r : kRetiredKeys) {
    if (!sameTail(r.path, path)) continue;
    switch (r.fate) {
      case Fate::Retired: return "retired: " + std::string(r.why) + ", see " + std::string(r.history);
      case Fate::Constant:
        if (!r.why.empty()) return std::string(r.why) + std::string(r.history) + "; see docs/configuration.md";
        return "now a constant in " + std::string(r.history) + "; see docs/configuration.md";
      case Fate::Moved: return "moved to " + std::string(r.history);
    }
  }
  const auto dot = path.rfind('.');
  if (dot == std::string::npos) return {};
  const std::string_view section(path.data(), dot), key = std::string_view(path).substr(dot + 1);
  for (const MovedSection& m : kMovedSections)
    // A lone "registration" is also the section of `hazmap register --config`, where the keys live.
    if (sameTail(m.from, section) && section != "registration")
      return "moved to " + std::string(m.to) + "." + std::string(key) + ": " + std::string(m.why);
  return {};
}

std::string movedAndConstantKeysMarkdown() {
  std::string moved_rows, constant_rows;
  for (const RetiredKey& r : kRetiredKeys) {
    const std::string row = "| `" + std::string(r.path) + "` | `" + std::string(r.history) + "` |\n";
    if (r.fate == Fate::Moved) moved_rows += row;
    if (r.fate == Fate::Constant) constant_rows += row;
  }
  for (const MovedSection& m : kMovedSections)
    moved_rows += "| `" + std::string(m.from) + ".*` (but its own keys) | `" + std::string(m.to) + ".*` |\n";
  return "| old key | now |\n|---|---|\n" + moved_rows +
         "\nInternal thresholds are not keys (issue 37: every key is a default path or a user's choice). Each is "
         "a named `constexpr` constant, with a line on why it has its value, in the file that uses it; the "
         "switches of adopted measures are the code itself. An old config naming one gets `unknown key 'X' (now a "
         "constant in FILE; see docs/configuration.md)`.\n\n| old key | constant in |\n|---|---|\n" +
         constant_rows;
}

}  // namespace hazmap::config_detail
