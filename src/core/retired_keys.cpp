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
      case Fate::Constant: return "now a constant in " + std::string(r.history) + "; see docs/configuration.md";
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

}  // namespace hazmap::config_detail
