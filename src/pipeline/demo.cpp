#include "hazmap/pipeline/demo.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <ostream>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/map/image.hpp"
#include "hazmap/pipeline/progress.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "hazmap/sim/simulator.hpp"

namespace hazmap {

std::string formatTable2(const DemoReport& report) {
  std::string s = fmt::format(
      "Table 2 — distance to the map built by the true trajectory ({} frames, {:.0f} m route)\n",
      report.frames, report.route_length_m);
  s += fmt::format("{:<44} {:>10} {:>11} {:>9} {:>8} {:>10} {:>6}\n", "Method", "paper [m]",
                   "hazmap [m]", "p95 [m]", "ATE [m]", "frames/s", "loops");
  for (const auto& r : report.rows)
    s += fmt::format("{:<44} {:>10.3f} {:>11.3f} {:>9.3f} {:>8.3f} {:>10.1f} {:>6}\n",
                     paperRowTitle(r.method), paperMapError(r.method), r.map_error_m,
                     r.map_error_p95_m, r.ate_m, r.frames_per_s, r.loops);
  return s;
}

DemoReport runDemo(const DemoConfig& config, std::ostream& out) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  DemoReport report;
  std::error_code ec;
  std::filesystem::create_directories(config.out_dir, ec);
  if (ec) fail(config.out_dir.string(), "cannot create demo folder: " + ec.message());

  sim::SimulatorConfig sim_config;  // the paper's experiment with its fixed noise defaults
  sim_config.scenario = config.scenario;
  sim_config.seed = config.seed;
  sim_config.max_frames = config.frames;
  const auto seq_dir = config.out_dir / "sequence";
  out << "Simulating '" << config.scenario << "' (seed " << config.seed << ") into " << seq_dir.string()
      << " ..." << std::endl;
  const sim::SimulationSummary sim = sim::writeSimulation(sim_config, seq_dir, /*overwrite=*/true);
  report.frames = sim.frames;
  report.route_length_m = sim.route_length;
  report.simulate_seconds = sim.total_seconds;
  out << fmt::format("  {} frames, {:.1f} m route, odometry drift mean {:.2f} m / final {:.2f} m, {:.1f} s\n",
                     sim.frames, sim.route_length, sim.drift.mean_position_error,
                     sim.drift.final_position_error, sim.total_seconds);

  const Sequence sequence = Sequence::open(seq_dir);
  std::vector<MapPanel> panels;
  std::vector<RunArtifacts> artifacts(config.methods.size());
  std::vector<SlamResult> results(config.methods.size());
  nlohmann::json table = nlohmann::json::object();
  for (std::size_t m = 0; m < config.methods.size(); ++m) {
    const SlamMethod method = config.methods[m];
    SlamConfig slam = SlamConfig::forMethod(method);
    slam.threads = config.threads;
    ProgressBar bar(toString(method), sequence.size(), config.progress ? -1 : 0);
    results[m] = runSlam(sequence, slam, [&](std::size_t done, std::size_t) { bar.update(done); });
    bar.finish();
    const RunSummary summary =
        writeRunOutputs(sequence, results[m], slam, OutputConfig{}, config.out_dir / toString(method),
                        &artifacts[m]);
    DemoRow row;
    row.method = method;
    row.map_error_m = summary.map_error ? summary.map_error->point.mean : 0.0;
    row.map_error_p95_m = summary.map_error ? summary.map_error->point.p95 : 0.0;
    row.ate_m = summary.trajectory ? summary.trajectory->ape.translation.rmse : 0.0;
    row.frames_per_s = results[m].framesPerSecond();
    row.loops = results[m].loops.size();
    for (const auto& f : results[m].frames) row.fallbacks += (usesIcp(method) && f.index > 0 && !f.icp_used);
    report.rows.push_back(row);
    table[toString(method)] = {{"map_error_m", row.map_error_m},
                               {"map_error_p95_m", row.map_error_p95_m},
                               {"ate_m", row.ate_m},
                               {"frames_per_s", row.frames_per_s},
                               {"loops", row.loops},
                               {"odometry_fallbacks", row.fallbacks},
                               {"paper_map_error_m", paperMapError(method)}};
    out << fmt::format("  {:<18} map error {:.3f} m, ATE {:.3f} m, {:.0f} frames/s, {} loops\n",
                       toString(method), row.map_error_m, row.ate_m, row.frames_per_s, row.loops);
  }
  for (std::size_t m = 0; m < config.methods.size(); ++m)
    panels.push_back({fmt::format("{} - map error {:.3f} m", toString(config.methods[m]),
                                  report.rows[m].map_error_m),
                      &artifacts[m].map, positionsOf(results[m].estimate), artifacts[m].hazards});
  TopDownConfig top;
  double z = 0;
  for (const auto& p : sequence.groundTruth() ? sequence.groundTruth()->poses : results[0].estimate.poses)
    z += p.translation().z();
  top.clip_above = z / static_cast<double>(sequence.size()) + 1.5;
  top.draw_hazard_labels = false;
  MontageConfig montage;
  montage.title = "hazmap demo: the five methods of Table 2 (heat red, water blue)";
  writePng(config.out_dir / "maps_side_by_side.png",
           renderMapMontage(panels, sequence.classTable(), top, montage));
  nlohmann::json doc = table;
  writeTextAtomically(config.out_dir / "table2.json", doc.dump(2) + "\n");
  report.total_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  out << "\n" << formatTable2(report);
  out << fmt::format("\nWrote {} (sequence/, one folder per method, maps_side_by_side.png, table2.json) in {:.1f} s\n",
                     config.out_dir.string(), report.total_seconds);
  return report;
}

}  // namespace hazmap
