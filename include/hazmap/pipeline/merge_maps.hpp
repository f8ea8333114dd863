#pragma once
// Merging missions (issue 34, part 3): `hazmap merge MAP_A MAP_B … --out MERGED`. Each map folder
// (map/map_folder.hpp) is opened and checked (format, files, class table); each later map is
// placed in the first map's frame by the machinery of `run --prior` (pipeline/prior_map.hpp):
// guess-free global registration with property-landmark constellations against the keyframes
// placed so far, verified by property ICP, two agreeing answers, ambiguous ones refused. A map
// that cannot be placed is reported and left out, never guessed. Every keyframe of a placed map
// then closes a verified loop to the keyframes it lands among (inter-session loops), and one pose
// graph — every map's own graph.g2o with its edges' information, plus those loops — is solved
// with the first map's first pose fixed: each map moves only as much as the new evidence says.
// The result is itself a map folder (hazmap-map/1: it can be a prior or merged again) with the
// map of all keyframes and its hazards, changes.json / changes.csv (each later mission's hazards
// against the first's) and merge.json (what was placed, every search attempt and loop, and the
// map error when every map's sequence has ground truth). Written into a temporary sibling folder
// and moved into place at the end: a failure leaves no half-written output.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/eval/map_error.hpp"
#include "hazmap/pipeline/prior_map.hpp"

namespace hazmap {

struct MergeOptions {
  int threads = 0;         ///< worker threads (0 = all cores)
  bool overwrite = false;  ///< replace an existing map folder at --out
  bool write_viewer = true;
  bool write_pngs = true;
};

/// One input map and where the merge put it.
struct MapPlacement {
  std::filesystem::path dir;
  bool placed = false;  ///< the first map always; a later one when localised
  /// Its frame f is node node_offset + f of the merged graph (and frame node_offset + f of the
  /// merged map); valid when placed.
  std::size_t node_offset = 0;
  std::size_t frames = 0, keyframes = 0;
  /// The search in the maps placed before it and its loops to them (empty for the first map).
  PriorLocalisation localisation;
  std::size_t inter_session_loops = 0;  ///< verified loops that joined the graph
};

/// The paper's map error over the keyframes (their clouds at their poses against the true poses).
struct MergeMapError {
  std::string what;  ///< "first map alone", "merged", "map N in the merge"
  MapErrorResult error;
};

struct MergeReport {
  std::vector<MapPlacement> maps;
  std::size_t nodes = 0, edges = 0, inter_session_loops = 0;
  /// Inter-session loops whose whitened error exceeds the χ² 99 % bound (6 dof) after the final
  /// solve: evidence the solution could not agree with.
  std::size_t loops_disagreeing = 0;
  std::vector<std::string> optimisation_notes;  ///< a solve that failed (poses kept as placed)
  std::vector<MergeMapError> map_errors;        ///< when every placed map's sequence has poses.txt
  std::string map_error_note;                   ///< why the map error was not measured
  std::size_t hazards = 0, changes = 0;
  double seconds = 0.0;
};

/// Merges the map folders `maps` (at least two, the first is the reference frame) into `out`.
/// Throws hazmap::Error (one line, naming the folder) on a map that cannot be opened, another
/// class table, a graph that does not match its map, the same folder twice, or an output folder
/// that is an input or exists (without `overwrite`, or not a map folder).
MergeReport mergeMaps(const std::vector<std::filesystem::path>& maps, const std::filesystem::path& out,
                      const MergeOptions& options = {});

/// merge.json's text and the summary's lines.
std::string mergeJson(const MergeReport& report);
std::string formatMergeSummary(const MergeReport& report, const std::filesystem::path& out);

}  // namespace hazmap
