#pragma once
// The pieces of localisation in a prior map (pipeline/prior_map.hpp): the run's keyframes, the
// prior's keyframes prepared once, the property-ICP verification against the prior, the search.
#include <Eigen/Geometry>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/pipeline/prior_map.hpp"
#include "hazmap/registration/correlative_search.hpp"
#include "hazmap/registration/global_registration.hpp"

namespace hazmap::pipeline_detail {

/// m: a sensor height this different from the prior's is warned about.
constexpr double kSensorHeightTolerance = 0.1;

/// Every frame's pose of a run (Trajectory::poses), indexed by frame.
using FramePoses = std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>;

/// The run's keyframes (keyframeFrames), their clouds as tracking saw them, downsampled.
struct RunKeyframes {
  std::vector<std::size_t> frames;
  std::vector<LabeledCloud> clouds;  ///< sensor frame
  std::vector<double> heights;       ///< sensorHeightAboveFloor of the full clouds
  /// Appends keyframe `frame` from its full cloud (sensor frame).
  void add(std::size_t frame, const LabeledCloud& full, const ClassTable& classes);
  /// Keyframe k with the keyframes just before it, placed in k's frame with the run's poses.
  LabeledCloud query(std::size_t k, const FramePoses& poses) const;
  /// Keyframe k with up to `before` keyframes before it, placed in k's frame.
  LabeledCloud query(std::size_t k, const FramePoses& poses, std::size_t before) const;
  double sensorHeight() const;  ///< median of the finite heights, NaN when none
};
RunKeyframes readRunKeyframes(ScanSource& scans, const SlamResult& result, const SlamConfig& config,
                              const ClassTable& classes);
/// The keyframes of a map folder (a map being merged into another), as a run's.
RunKeyframes mapKeyframes(const MapFolder& map, const ClassTable& classes);

/// The prior's keyframes, prepared once: their poses, the global registration target of all of
/// them in the prior's frame, and their clouds for the verification's submaps. A prior whose map
/// folder holds a search overview made as this build would make it (prior_overview.hpp) is
/// prepared from it and reads a keyframe's cloud only when a submap needs it; otherwise every
/// keyframe is read and the overview made here, to the same bits. A merge
/// (pipeline/merge_maps.hpp) adds one map after another, each a segment of its own, and prepares
/// the target again.
class PriorIndex {
 public:
  /// The prior's keyframes at their poses, prepared.
  PriorIndex(const MapFolder& prior, const ClassTable& classes, const SlamConfig& config);
  /// Empty: add() maps, then prepare().
  explicit PriorIndex(const SlamConfig& config);
  /// Appends `map`'s keyframes as a new segment, keyframe k at poses[k] (prior frame), tagged
  /// tags[k] (the merge's graph node). Throws hazmap::Error naming a keyframe that cannot be read.
  void add(const MapFolder& map, const std::vector<Eigen::Isometry3d>& poses, const std::vector<std::size_t>& tags,
           const ClassTable& classes);
  /// (Re)builds the global registration target over all keyframes at their current poses.
  void prepare(const ClassTable& classes, const std::string& where);
  std::size_t size() const { return poses_.size(); }
  const Eigen::Isometry3d& pose(std::size_t k) const { return poses_.at(k); }
  void setPose(std::size_t k, const Eigen::Isometry3d& pose) { poses_.at(k) = pose; }
  std::size_t tag(std::size_t k) const { return tags_.at(k); }
  std::size_t segment(std::size_t k) const { return segments_.at(k); }
  /// The prior keyframe nearest `position` (prior frame) and its distance.
  std::size_t nearest(const Eigen::Vector3d& position, double& distance) const;
  /// Keyframe k with its neighbours by index in its segment, placed in k's frame (the
  /// verification target). Throws hazmap::Error naming a keyframe cloud that cannot be read.
  LabeledCloud submap(std::size_t k) const;
  const GlobalRegistrationTarget& overview() const { return overview_; }
  /// The overview's footprint for the correlative search, and where its sensors were (x, y).
  const CorrelativeTarget& footprint() const { return footprint_; }
  std::vector<Eigen::Vector2d> places() const;
  const GlobalRegistrationConfig& globalConfig() const { return global_; }
  /// The target came from the map folder's stored overview (not rebuilt from the keyframes).
  bool usedStoredOverview() const { return used_stored_overview_; }
  /// Keyframe clouds read so far (all of them unless the stored overview was used).
  std::size_t keyframesRead() const;

 private:
  /// Keyframe k's cloud at the keyframe voxel (sensor frame), read on first use.
  const LabeledCloud& cloud(std::size_t k) const;
  /// The global registration target from the overview (fails, naming `where`, without keyframes).
  void prepareTarget(const LabeledCloud& overview, const ClassTable& classes, const std::string& where);

  std::vector<Eigen::Isometry3d> poses_;
  std::vector<std::size_t> tags_, segments_;
  std::size_t segment_count_ = 0;
  // Read on demand from the map (prepared from its stored overview), else filled by add().
  std::shared_ptr<const MapFolder> lazy_map_;
  std::shared_ptr<const ClassTable> lazy_classes_;
  mutable std::mutex clouds_mutex_;
  mutable std::vector<std::optional<LabeledCloud>> clouds_;  ///< at the keyframe voxel, sensor frame
  std::vector<LabeledCloud> overview_clouds_;  ///< keyframeOverview of each (add() only)
  GlobalRegistrationConfig global_;
  GlobalRegistrationTarget overview_;
  CorrelativeTarget footprint_;
  bool used_stored_overview_ = false;
};

struct PriorVerification {
  bool accepted = false;
  bool in_reach = false;  ///< a prior keyframe lay within reach of the guess
  std::string outcome;
  std::size_t prior_keyframe = 0;
  Eigen::Isometry3d T_world_query = Eigen::Isometry3d::Identity();  ///< prior world ← query
  RegistrationResult registration;  ///< target = the prior keyframe's submap
};

/// Property ICP of `query` against the submap of the prior keyframe nearest `guess` (prior world
/// ← query), from `guess`: accepted when it converged, fits (loop verification's min_fitness and
/// max_rmse) and leaves no direction degenerate.
PriorVerification verifyInPrior(const PriorIndex& prior, const LabeledCloud& query, const Eigen::Isometry3d& guess,
                                const ClassTable& classes, const SlamConfig& config);

/// The search, keyframe by keyframe: global registration against the prior, verification, and
/// two verified answers of two keyframes that agree. Sets out.state (Localised) and out.T_prior_run.
void searchPrior(const PriorIndex& prior, const RunKeyframes& run, const FramePoses& poses,
                 const ClassTable& classes, const SlamConfig& config, PriorLocalisation& out);

/// A verified loop from a prior keyframe to a frame of the run.
struct PriorEdge {
  std::size_t prior_keyframe = 0, frame = 0;
  Eigen::Isometry3d T_prior_frame;
  Matrix6d information;
};

/// Loops to the prior once localised (`poses` in the prior's frame): every keyframe registered to
/// the prior keyframes nearest where the localisation puts it; a correction beyond 0.5 m / 0.05
/// rad is refused (another place). Each attempt is appended to out.loops.
std::vector<PriorEdge> loopsToPrior(const PriorIndex& prior, const RunKeyframes& run, const FramePoses& poses,
                                    const ClassTable& classes, const SlamConfig& config, PriorLocalisation& out);

/// The confirmation rule, for `run --prior` and `merge` alike: a placement stands only when some
/// loop to the prior verified and at least kMinConfirmedShare of the keyframes that land among the
/// prior's keyframes (out.loops' in_reach) verify there. Else the state becomes NeverLocalised,
/// out.optimisation_note says why (`prior` names what was searched: "the prior", "the maps placed
/// before it"), every loop is marked refused and false is returned: the placement is not used.
bool placementConfirmed(const std::vector<PriorEdge>& edges, const std::string& prior, PriorLocalisation& out);

}  // namespace hazmap::pipeline_detail
