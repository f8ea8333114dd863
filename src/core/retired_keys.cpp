// Keys of experiments that were measured and not adopted (issue 37). The code is gone; a YAML
// file or `--set` naming one gets the usual unknown-key error plus where its write-up lives, so a
// user's old config explains itself. An experiment not adopted leaves as a dated write-up in
// docs/history/, and its keys join this table.
#include "hazmap/core/retired_keys.hpp"

#include <string_view>
#include <utility>

namespace hazmap::config_detail {

namespace {

constexpr std::string_view kNotAdopted = "measured and not adopted";
constexpr std::string_view kAlwaysOn = "the switch of an adopted measure, now always on";

struct RetiredKey {
  std::string_view path;     ///< dotted, from the run config's top (`hazmap run --set` spelling)
  std::string_view history;  ///< the write-up, relative to the repository
  std::string_view why = kNotAdopted;
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
  for (const RetiredKey& r : kRetiredKeys)
    if (sameTail(r.path, path)) return "retired: " + std::string(r.why) + ", see " + std::string(r.history);
  return {};
}

}  // namespace hazmap::config_detail
