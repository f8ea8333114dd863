// hazmap eval: trajectory metrics (evo-compatible APE/RPE, KITTI segment errors) and, with
// --scans, the paper's map error.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <tuple>

#include "command.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/eval/map_error.hpp"
#include "hazmap/eval/trajectory_metrics.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/map/render.hpp"

namespace hazmap::cli {
namespace {

struct EvalOptions {
  std::string gt, est, format = "auto", align = "se3", delta_unit = "m", scans;
  double delta = 10.0;
  double max_dt = 0.01;
  bool json = false;
  std::size_t map_points = 1000;
  std::string plot;                  ///< PNG of the error against distance travelled
  std::vector<std::string> compare;  ///< more estimates drawn on the plot
};

Trajectory readWith(const std::string& path, const std::string& format) {
  if (format == "kitti") return readTrajectory(path, TrajectoryFormat::Kitti);
  if (format == "tum") return readTrajectory(path, TrajectoryFormat::Tum);
  return readTrajectoryAuto(path);
}

bool isTumFile(const std::string& path, const std::string& format) {
  if (format != "auto") return format == "tum";
  return detectTrajectoryFormat(path) == TrajectoryFormat::Tum;
}

// A series' name: the folder a run wrote its trajectory into (hazmap-demo/icp/trajectory.kitti
// → "icp"), else the file's stem.
std::string seriesLabel(const std::string& path) {
  const std::filesystem::path p = std::filesystem::absolute(path).lexically_normal();
  const std::string folder = p.parent_path().filename().string();
  return p.stem() == "trajectory" && !folder.empty() ? folder : p.stem().string();
}

void writeErrorPlot(const EvalOptions& o, const Trajectory& gt, const ApeResult& ape, Alignment align, bool tum) {
  std::vector<ErrorSeries> series{{seriesLabel(o.est), distanceTravelled(gt), ape.errors, seriesColor(0)}};
  for (const std::string& path : o.compare) {
    Trajectory g = gt, e = readWith(path, o.format);
    checkTrajectory(e, path);
    if (tum) std::tie(g, e) = associateTrajectories(readWith(o.gt, o.format), e, o.max_dt);
    if (g.size() != e.size())
      fail(path, "has " + std::to_string(e.size()) + " poses but the ground truth has " + std::to_string(g.size()));
    series.push_back({seriesLabel(path), distanceTravelled(g), computeApe(g, e, align).errors, seriesColor(series.size())});
  }
  ErrorPlotConfig config;
  config.title = "Trajectory error (APE, " + o.align + " alignment) vs distance travelled";
  writePng(o.plot, renderErrorPlot(series, config));
}

void run(const EvalOptions& o) {
  if (!o.compare.empty() && o.plot.empty()) fail("--compare", "only draws on a --plot");
  const auto align = parseAlignment(o.align);
  if (!align) fail("--align", "expected se3, sim3 or none, got '" + o.align + "'");
  if (o.format != "auto" && o.format != "kitti" && o.format != "tum")
    fail("--format", "expected kitti, tum or auto, got '" + o.format + "'");
  if (o.delta_unit != "m" && o.delta_unit != "frames")
    fail("--delta-unit", "expected m or frames, got '" + o.delta_unit + "'");

  Trajectory gt = readWith(o.gt, o.format);
  Trajectory est = readWith(o.est, o.format);
  checkTrajectory(gt, o.gt);
  checkTrajectory(est, o.est);
  const bool tum = isTumFile(o.gt, o.format) && isTumFile(o.est, o.format);
  if (tum) {
    std::tie(gt, est) = associateTrajectories(gt, est, o.max_dt);
  } else if (gt.size() != est.size()) {
    fail(o.est, "has " + std::to_string(est.size()) + " poses but the ground truth " + o.gt +
                    " has " + std::to_string(gt.size()) +
                    " (KITTI files are compared row by row; use TUM files to match by time)");
  }

  TrajectoryEvalConfig config;
  config.ape_alignment = *align;
  config.rpe.delta = o.delta;
  config.rpe.unit = o.delta_unit == "m" ? DeltaUnit::Metres : DeltaUnit::Frames;
  const TrajectoryEvaluation e = evaluateTrajectory(gt, est, config);
  if (!o.plot.empty()) writeErrorPlot(o, gt, e.ape, *align, tum);

  std::optional<MapErrorResult> map_error;
  if (!o.scans.empty()) {
    const Sequence seq = Sequence::open(o.scans);
    if (seq.size() != gt.size())
      fail(o.scans, "has " + std::to_string(seq.size()) + " scans but the trajectories have " +
                        std::to_string(gt.size()) + " poses");
    MapErrorConfig mc;
    mc.max_points_per_frame = o.map_points;
    MapErrorAccumulator acc(mc);
    for (std::size_t i = 0; i < seq.size(); ++i) acc.addFrame(seq.frame(i), est.poses[i], gt.poses[i]);
    map_error = acc.result();
  }

  if (o.json) {
    nlohmann::json j = nlohmann::json::parse(toJson(e));
    j["map_error"] = map_error ? nlohmann::json::parse(toJson(*map_error)) : nlohmann::json();
    std::cout << j.dump(2) << "\n";
  } else {
    std::cout << toText(e);
    if (map_error) {
      const auto& p = map_error->point;
      std::cout.setf(std::ios::fixed);
      std::cout.precision(4);
      std::cout << "map error [m]    mean " << p.mean << "  median " << p.median << "  p95 " << p.p95
                << "  (" << p.count << " points, " << map_error->frames << " frames)\n"
                << "cloud-to-cloud   mean " << map_error->c2c.mean << "  median "
                << map_error->c2c.median << "  p95 " << map_error->c2c.p95 << "\n";
    }
  }
}

const RegisterCommand kRegister{{
    "eval",
    "Trajectory metrics as evo and the KITTI devkit compute them (APE, RPE, segment errors); "
    "with --scans also the map error of the paper's Table 2.",
    [](CLI::App& app) {
      auto o = std::make_shared<EvalOptions>();
      app.add_option("--gt", o->gt, "Ground-truth trajectory (KITTI 3x4 rows or TUM)")
          ->required()->check(CLI::ExistingFile);
      app.add_option("--est", o->est, "Estimated trajectory (same format)")
          ->required()->check(CLI::ExistingFile);
      app.add_option("--format", o->format, "kitti | tum | auto (guess from the column count)");
      app.add_option("--align", o->align,
                     "APE alignment: se3 (Umeyama, evo --align), sim3 (with scale), none");
      app.add_option("--delta", o->delta, "RPE pair spacing (metres of path, or frames)");
      app.add_option("--delta-unit", o->delta_unit, "m | frames");
      app.add_option("--max-dt", o->max_dt, "TUM: largest time-stamp difference of a pair (s)");
      app.add_option("--scans", o->scans,
                     "Sequence folder with one scan per pose: also report the map error");
      app.add_option("--map-points", o->map_points, "Map error: points used per scan (0 = all)");
      app.add_flag("--json", o->json, "Print one JSON object instead of text");
      app.add_option("--plot", o->plot, "Write a PNG of the translation error against distance travelled");
      app.add_option("--compare", o->compare,
                     "More estimates (same format) drawn on the --plot, one curve each (repeatable)")
          ->check(CLI::ExistingFile);
      app.callback([o] { run(*o); });
    },
}};

}  // namespace
}  // namespace hazmap::cli
