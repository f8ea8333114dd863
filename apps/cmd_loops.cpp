// hazmap loops: loop closure from property landmarks over a sequence folder, a bag or a capture
// (see docs/loop_closure.md).
#include <fmt/format.h>

#include <chrono>
#include <iostream>
#include <nlohmann/json.hpp>

#include "command.hpp"
#include "config_options.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/loop/loop_closure.hpp"
#include "hazmap/preprocess/deskew.hpp"
#include "source_flags.hpp"

namespace hazmap::cli {
namespace {

struct LoopsOptions {
  std::string sequence;
  std::string estimate;
  std::string method;
  std::string config;
  std::string out;
  std::size_t frames = 0;
  SourceFlags source;
};

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

nlohmann::json poseJson(const Eigen::Isometry3d& T) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 3; ++r) rows.push_back({T(r, 0), T(r, 1), T(r, 2), T(r, 3)});
  return rows;
}

/// Adds one keyframe's detection to the counts (candidates checked against the truth, if any).
void countDetection(const LoopDetection& det, const PoseList& truth, std::size_t& candidates,
                    std::size_t& true_candidates, std::size_t& verified, std::size_t& gated) {
  candidates += det.candidates.size();
  if (!truth.empty())
    for (const auto& c : det.candidates) {
      LoopClosure as_loop;
      as_loop.from = c.match;
      as_loop.to = c.query;
      as_loop.T_from_to = c.initial_guess;
      true_candidates += isTrueLoop(as_loop, truth, 1.0, 0.1);
    }
  for (const auto& v : det.verifications) verified += v.accepted || v.reason.rfind("drift gate", 0) == 0;
  for (const auto& g : det.gates) gated += !g.accepted;
}

void printAgainstTruth(const std::vector<LoopClosure>& accepted, const std::vector<LoopClosure>& loops,
                       const PoseList& truth) {
  if (truth.empty()) return;
  auto countTrue = [&](const std::vector<LoopClosure>& ls) {
    std::size_t k = 0;
    for (const auto& l : ls) k += isTrueLoop(l, truth);
    return k;
  };
  std::cout << fmt::format("against poses.txt: accepted {} true / {} false; kept {} true / {} false\n",
                           countTrue(accepted), accepted.size() - countTrue(accepted), countTrue(loops),
                           loops.size() - countTrue(loops));
}

void writeLoopsJson(const LoopsOptions& o, const LoopClosureConfig& config, std::size_t n,
                    const std::vector<LoopClosure>& loops, const PoseList& truth) {
  nlohmann::json j;
  j["sequence"] = o.sequence;
  j["frames"] = n;
  j["method"] = toString(config.method);
  j["loops"] = nlohmann::json::array();
  for (const auto& l : loops) {
    nlohmann::json e;
    e["from"] = l.from;
    e["to"] = l.to;
    e["source"] = toString(l.source);
    e["T_from_to"] = poseJson(l.T_from_to);
    e["information"] = std::vector<double>(l.information.data(), l.information.data() + 36);
    e["fitness"] = l.fitness;
    e["rmse"] = l.rmse;
    if (!truth.empty()) e["true"] = isTrueLoop(l, truth);
    j["loops"].push_back(e);
  }
  AtomicFile file(o.out);
  file.stream() << j.dump(1) << "\n";
  file.commit();
}

void runLoops(const LoopsOptions& o, bool method_given, const ParameterOptions& params) {
  LoopClosureConfig config;
  if (!o.config.empty()) config = LoopClosureConfig::fromYamlFile(o.config);
  if (method_given) {
    if (o.method == "constellation") config.method = CandidateMethod::Constellation;
    else if (o.method == "distance") config.method = CandidateMethod::Distance;
    else if (o.method == "both") config.method = CandidateMethod::Both;
    else fail("--method", "must be constellation, distance or both (got '" + o.method + "')");
  }
  params.applySettings(config);
  const auto scans = openScanSource(o.sequence, o.source.options(std::nullopt, true));
  // The estimate: --estimate's poses, else the recording's wheel odometry as the scans come.
  PoseList estimate;
  if (!o.estimate.empty()) {
    const Trajectory est = readTrajectoryAuto(o.estimate);
    estimate.assign(est.poses.begin(), est.poses.end());
  }
  PoseList truth;
  bool with_truth = true;
  DeskewConfig deskew_config;
  deskew_config.enabled = !o.source.no_deskew;
  deskew_config.motion = DeskewMotion::WheelOdometry;  // the only motion known without tracking
  StreamDeskewer deskewer(deskew_config);

  LoopDetector detector(params.propertyIcp().applyTo(scans->classTable()), config);
  std::size_t landmarks = 0, candidates = 0, true_candidates = 0, verified = 0, gated = 0;
  double t_read = 0, t_detect = 0;
  std::size_t n = 0;
  for (std::optional<Scan> scan; (o.frames == 0 || n < o.frames) && (scan = scans->next()); ++n) {
    const std::size_t i = n;
    if (o.estimate.empty()) {
      if (!scan->odometry)
        fail(o.sequence, "no wheel odometry (odometry.txt or an odometry topic); give the pose estimate "
                         "with --estimate");
      estimate.push_back(*scan->odometry);
    } else if (estimate.size() <= i) {
      fail(o.estimate, fmt::format("has {} poses, the recording has more scans", estimate.size()));
    }
    with_truth = with_truth && scan->ground_truth;
    if (with_truth) truth.push_back(*scan->ground_truth);
    auto t0 = Clock::now();
    const std::optional<Eigen::Isometry3d> increment =
        i > 0 ? std::optional(estimate[i - 1].inverse() * estimate[i]) : std::nullopt;
    deskewer.apply(scan->cloud, scan->stamp, increment);
    detector.addKeyframe(std::move(scan->cloud));
    t_read += secondsSince(t0);
    landmarks += detector.landmarks(i).size();
    t0 = Clock::now();
    const LoopDetection det = detector.detect(i, estimate);
    t_detect += secondsSince(t0);
    static const PoseList kNoTruth;
    countDetection(det, with_truth ? truth : kNoTruth, candidates, true_candidates, verified, gated);
  }
  if (n == 0) fail(o.sequence, "has no scans");
  estimate.resize(n);
  if (!with_truth) truth.clear();
  const auto t0 = Clock::now();
  const std::vector<LoopClosure> loops = detector.consistentLoops(estimate);
  const double t_consistency = secondsSince(t0);

  std::cout << fmt::format("{} frames, {:.2f} landmarks/frame, method {}\n", n,
                           static_cast<double>(landmarks) / n, toString(config.method));
  std::cout << fmt::format("candidates {}{}, ICP-verified {}, rejected by the drift gate {}, accepted {}, "
                           "pairwise-consistent {}\n",
                           candidates, truth.empty() ? "" : fmt::format(" ({} true)", true_candidates),
                           verified, gated, detector.acceptedLoops().size(), loops.size());
  printAgainstTruth(detector.acceptedLoops(), loops, truth);
  std::cout << fmt::format("time: read + landmarks {:.2f} s, candidates + verification {:.2f} s, "
                           "consistency {:.3f} s\n",
                           t_read, t_detect, t_consistency);
  if (!o.out.empty()) writeLoopsJson(o, config, n, loops, truth);
}

void setupLoops(CLI::App& app) {
  auto opt = std::make_shared<LoopsOptions>();
  app.add_option("sequence", opt->sequence,
                 "Sequence folder (velodyne/, labels/, odometry.txt, ...), bag (.bag, .mcap, rosbag2 folder) "
                 "or capture (.pcap)")
      ->required();
  app.add_option("--estimate", opt->estimate,
                 "Pose estimate (KITTI or TUM) the distance search and the consistency checks use; "
                 "default: the sequence's odometry.txt");
  auto* method = app.add_option("--method", opt->method,
                                "Candidate search: constellation (property landmarks), distance "
                                "(nearby in the estimate) or both; default from --config, else constellation");
  app.add_option("--config", opt->config, "YAML with a loop_closure: section (docs/loop_closure.md)");
  app.add_option("--frames", opt->frames, "Use only the first N frames (0 = all)");
  app.add_option("--out", opt->out, "Write the consistent loops (from, to, T_from_to, information) as JSON");
  opt->source.add(app);
  auto params = addParameterOptions(app, "keys of the loop_closure section, e.g. verification.max_rmse=0.3");
  app.callback([opt, method, params]() { runLoops(*opt, method->count() > 0, *params); });
}

const RegisterCommand kRegister{{"loops",
                                 "Find loop closures in a sequence from property landmarks; "
                                 "reports candidates, verified and consistent loops",
                                 setupLoops}};

}  // namespace
}  // namespace hazmap::cli
