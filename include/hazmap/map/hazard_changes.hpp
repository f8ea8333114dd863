#pragma once
// What changed between two missions (issue 34, part 4): the hazards of a prior map against
// those of a run localised in it (both in the prior's frame). Each prior hazard is found again
// (unchanged, moved, grown, shrunk, value changed), gone, or not re-observed; each hazard of
// the run not in the prior is new. "gone" only where the run actually looked: its map has
// surface points where the hazard was (out of view is `not_re_observed`, never `gone`).
#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/map/hazards.hpp"

namespace hazmap {

struct HazardChange {
  /// unchanged | moved | grown | shrunk | value_changed (one or more, ';'-joined in the CSV) |
  /// gone | not_re_observed | new | part_of (a piece of a matched hazard on its own side, seen
  /// apart: its changes are that hazard's)
  std::vector<std::string> kinds;
  std::string class_name;
  int before_id = 0, after_id = 0;  ///< hazards.json ids (0 = none)
  std::optional<Eigen::Vector3d> before, after;  ///< centroids
  double moved_m = 0.0;
  double area_before_m2 = 0.0, area_after_m2 = 0.0;
  std::optional<double> value_before, value_after;  ///< max_property
  std::vector<FrameRange> frames_before, frames_after;  ///< frames that saw it, in each mission
  /// 0–1: how much the run's evidence supports the verdict (frames that saw the hazard, or for
  /// gone the surface points where it was), saturating at kConfidentFrames / kConfidentPoints.
  double confidence = 0.0;
  /// In a merge (pipeline/merge_maps.hpp): the later mission (1-based input number) compared with
  /// the first; 0 for a run with --prior (changes.json then has no "mission").
  int mission = 0;
  bool changed() const;  ///< anything but unchanged, not_re_observed and part_of
};

/// `after_map`: the run's map (cells' centroids, GlobalMap::cloud()) in the prior's frame.
std::vector<HazardChange> compareHazards(const std::vector<Hazard>& before, const std::vector<Hazard>& after,
                                         const LabeledCloud& after_map);

/// One entry of changes.json (a JSON object's text; "mission" only when set).
std::string hazardChangeJson(const HazardChange& change);

/// Reads changes.json back. Throws hazmap::Error naming the file when it is missing or broken.
std::vector<HazardChange> readHazardChanges(const std::filesystem::path& path);

/// changes.json ({"changes": [...], "counts": {kind: n}}) and changes.csv. Atomic. When any
/// change has a mission, each entry has "mission" and the CSV a first column `mission`.
void writeHazardChanges(const std::filesystem::path& dir, const std::vector<HazardChange>& changes);

}  // namespace hazmap
