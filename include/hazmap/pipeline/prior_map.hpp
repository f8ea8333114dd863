#pragma once
// Entering again (issue 34, part 2): a run localised in the map of an earlier mission
// (`hazmap run NEW --prior MAP_DIR`). The run tracks in its own frame from an unknown start
// (startUnknown: no ground truth, odometry re-based at the first scan); then its keyframes, in
// order, are placed in the prior's frame by guess-free global registration (FPFH and property-
// landmark constellations, the relocalisation machinery) against the prior's keyframes, each
// answer verified by property ICP against the prior keyframes it lands among; an ambiguous or
// unverified answer is refused. Two verified answers of two keyframes that agree (composed with
// the run's own estimate) localise the run. From then on every keyframe is registered to its nearest prior keyframes
// (loops to the prior), and the run's graph, with those edges and the prior keyframes held by
// stiff edges, is optimised in the prior's frame. Never a silent guess: until localised the run
// says it is searching, and a run never localised keeps its own frame and says so.
#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "hazmap/map/map_folder.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "hazmap/sources/scan_source.hpp"

namespace hazmap {

enum class PriorState { Searching, Localised, NeverLocalised };
const char* toString(PriorState state);

/// One keyframe's search (before localisation) or loop to the prior (after).
struct PriorAttempt {
  std::size_t frame = 0;
  bool accepted = false;
  std::string outcome;  ///< why refused, or what was found
  std::size_t prior_keyframe = 0;  ///< the prior keyframe it was verified against
  /// Where the verification put the keyframe (prior world ← keyframe; identity when global
  /// registration found nothing to verify).
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  /// A prior keyframe lay within reach of where the keyframe was put (it could be verified).
  bool in_reach = false;
};

struct PriorLocalisation {
  PriorState state = PriorState::Searching;
  std::size_t frame = 0;  ///< localised at this frame (state Localised)
  /// Prior world ← this run's tracking frame (state Localised).
  Eigen::Isometry3d T_prior_run = Eigen::Isometry3d::Identity();
  /// Frame `frame`'s pose when it was localised (before the joint optimisation).
  Eigen::Isometry3d localised_pose = Eigen::Isometry3d::Identity();
  std::vector<PriorAttempt> search;  ///< keyframes tried until localised
  std::vector<PriorAttempt> loops;   ///< keyframes after: loops to the prior keyframes
  std::vector<std::string> warnings; ///< differences from the prior that are not errors
  double search_seconds = 0.0, total_seconds = 0.0;
  /// Preparing the prior's search (its global registration target) and where it came from: the
  /// map folder's stored search overview, or rebuilt from every keyframe (older folders, another
  /// class table).
  double prepare_seconds = 0.0;
  bool stored_overview = false;
  std::size_t prior_keyframes = 0, prior_keyframes_read = 0;  ///< read: clouds the run needed
  /// Mean of search_seconds over the keyframes searched (the cost of one localisation attempt).
  double seconds_per_attempt = 0.0;
  bool optimised = false;  ///< the joint graph was solved (else the poses are only moved by T)
  std::string optimisation_note;
};

/// A source that hides what a run entering a prior map must not know: its ground truth, and
/// where its wheel odometry's frame lies (re-based so the first scan's odometry is the identity).
std::unique_ptr<ScanSource> startUnknown(std::unique_ptr<ScanSource> inner);

/// Throws hazmap::Error (one line, naming the first difference) when `prior`'s class table does
/// not give the same ids the same names and kinds as `classes`.
void checkPriorClasses(const MapFolder& prior, const ClassTable& classes);

/// Localises the finished run `result` (tracked in its own frame from an unknown start) in
/// `prior`, adds its loops to the prior and re-optimises; on success every pose of `result`
/// (estimate, tracked, odometry_only, graph) is in the prior's frame. `scans` is a fresh pass
/// over the run's input (its keyframes' clouds are read from it).
PriorLocalisation localiseInPrior(const MapFolder& prior, ScanSource& scans, SlamResult& result,
                                  const SlamConfig& config);

/// run.json's "prior" object and the summary's line.
std::string priorJson(const PriorLocalisation& p, const std::filesystem::path& prior_dir);
std::string formatPriorSummary(const PriorLocalisation& p);

}  // namespace hazmap
