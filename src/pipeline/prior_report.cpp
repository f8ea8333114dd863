// What a run entering a prior map knows and reports (pipeline/prior_map.hpp): the source that
// hides its start, the class-table check, run.json's "prior" and the summary's line.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/pipeline/prior_map.hpp"
#include "hazmap/sources/forwarding_source.hpp"
#include "map/map_folder_json.hpp"

namespace hazmap {

const char* toString(PriorState state) {
  switch (state) {
    case PriorState::Searching: return "searching";
    case PriorState::Localised: return "localised";
    case PriorState::NeverLocalised: return "never localised";
  }
  return "?";
}

using map_folder_detail::poseJson;

namespace {

class StartUnknownSource : public ForwardingScanSource {
 public:
  using ForwardingScanSource::ForwardingScanSource;
  std::optional<Scan> next() override {
    std::optional<Scan> scan = ForwardingScanSource::next();
    if (!scan) return scan;
    scan->ground_truth.reset();
    if (scan->odometry) {
      if (!first_odometry_inverse_) first_odometry_inverse_ = scan->odometry->inverse();
      scan->odometry = normalized(*first_odometry_inverse_ * *scan->odometry);
    }
    return scan;
  }
 private:
  std::optional<Eigen::Isometry3d> first_odometry_inverse_;
};

std::string describeClass(const ClassInfo* c) {
  return c ? fmt::format("'{}' ({})", c->name, toString(c->kind)) : "absent";
}

}  // namespace

std::unique_ptr<ScanSource> startUnknown(std::unique_ptr<ScanSource> inner) {
  return std::make_unique<StartUnknownSource>(std::move(inner));
}

void checkPriorClasses(const MapFolder& prior, const ClassTable& classes) {
  std::vector<ClassId> ids = prior.classes().ids();
  for (ClassId id : classes.ids()) ids.push_back(id);
  for (ClassId id : ids) {
    const ClassInfo* there = prior.classes().find(id);
    const ClassInfo* here = classes.find(id);
    if (there && here && there->name == here->name && there->kind == here->kind) continue;
    fail(prior.dir().string(), fmt::format("made with another class table: class {} is {} there, {} here", id,
                                           describeClass(there), describeClass(here)));
  }
}

std::string priorJson(const PriorLocalisation& p, const std::filesystem::path& prior_dir) {
  const auto attempts = [](const std::vector<PriorAttempt>& list) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& x : list)
      a.push_back({{"frame", x.frame}, {"accepted", x.accepted}, {"prior_keyframe", x.prior_keyframe},
                   {"outcome", x.outcome}, {"pose", poseJson(x.pose)}});
    return a;
  };
  nlohmann::json j = {{"map", prior_dir.string()}, {"state", toString(p.state)}, {"warnings", p.warnings},
                      {"search", attempts(p.search)}, {"loops_to_prior", attempts(p.loops)},
                      {"search_seconds", p.search_seconds}, {"seconds_per_attempt", p.seconds_per_attempt},
                      {"total_seconds", p.total_seconds}, {"optimised", p.optimised},
                      {"prepare_seconds", p.prepare_seconds},
                      {"search_overview", p.stored_overview ? "stored in the map" : "rebuilt from the keyframes"},
                      {"prior_keyframes", p.prior_keyframes}, {"prior_keyframes_read", p.prior_keyframes_read}};
  if (!p.optimisation_note.empty()) j["optimisation_note"] = p.optimisation_note;
  if (p.state == PriorState::Localised) {
    j["localised_at_frame"] = p.frame;
    j["T_prior_run"] = poseJson(p.T_prior_run);
    j["localised_pose"] = poseJson(p.localised_pose);
  }
  return j.dump();
}

std::string formatPriorSummary(const PriorLocalisation& p) {
  std::size_t loops = 0;
  for (const auto& l : p.loops) loops += l.accepted;
  std::string s;
  for (const auto& w : p.warnings) s += "Warning: " + w + "\n";
  if (p.state != PriorState::Localised)
    return s + fmt::format("Prior map: never localised ({} keyframes searched{}); the run keeps its own frame.\n",
                           p.search.size(), p.optimisation_note.empty() ? "" : "; " + p.optimisation_note);
  return s + fmt::format("Prior map: localised at frame {} ({} keyframes searched, {:.2f} s each), {} loops to the "
                         "prior's keyframes; poses in the prior's frame{}.\n",
                         p.frame, p.search.size(), p.seconds_per_attempt, loops,
                         p.optimised ? "" : " (joint graph not solved: " + p.optimisation_note + ")");
}

}  // namespace hazmap
