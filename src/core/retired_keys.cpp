// Keys of experiments that were measured and not adopted (issue 37). The code is gone; a YAML
// file or `--set` naming one gets the usual unknown-key error plus where its write-up lives, so a
// user's old config explains itself. An experiment not adopted leaves as a dated write-up in
// docs/history/, and its keys join this table.
#include "hazmap/core/retired_keys.hpp"

#include <string_view>
#include <utility>

namespace hazmap::config_detail {

namespace {

struct RetiredKey {
  std::string_view path;     ///< dotted, from the run config's top (`hazmap run --set` spelling)
  std::string_view history;  ///< the write-up, relative to the repository
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
    if (sameTail(r.path, path)) return "retired: measured and not adopted, see " + std::string(r.history);
  return {};
}

}  // namespace hazmap::config_detail
