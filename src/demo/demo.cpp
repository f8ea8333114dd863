#include "hazmap/demo/demo.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <ostream>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/map/image.hpp"
#include "hazmap/demo/demo_index.hpp"
#include "hazmap/demo/demo_simulator.hpp"
#include "hazmap/pipeline/progress.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "hazmap/sim/simulator.hpp"

namespace hazmap {

OutputConfig demoRunOutputs() {
  OutputConfig outputs;
  outputs.write_map_folder = false;
  return outputs;
}


namespace {

// The odometry row integrates encoder increments: there is no per-frame work to rate.
std::string rate(const DemoRow& r) {
  return r.method == SlamMethod::Odometry ? "-" : fmt::format("{:.1f}", r.frames_per_s);
}

nlohmann::json rowJson(const DemoRow& r) {
  return {{"map_error_m", r.map_error_m},
          {"map_error_p95_m", r.map_error_p95_m},
          {"ate_m", r.ate_m},
          {"frames_per_s", r.frames_per_s},
          {"loops", r.loops},
          {"odometry_fallbacks", r.fallbacks},
          {"edge_nees", {{"odometry_mean", r.nees_odometry}, {"odometry_edges", r.odometry_edges},
                         {"loop_mean", r.nees_loop}, {"loop_edges", r.loop_edges}}},
          {"tracking", r.tracking == OdometryMode::FrameToFrame ? "frame-to-frame" : "frame-to-map"},
          {"paper_map_error_m", paperMapError(r.method)}};
}

}  // namespace

std::string formatTable2(const DemoReport& report) {
  const bool both = report.map_rows.size() == report.rows.size();
  std::string s = fmt::format(
      "Table 2 — distance to the map built by the true trajectory ({} frames, {:.0f} m route)\n",
      report.frames, report.route_length_m);
  if (both)
    s += fmt::format("{:<44} {:>9}   {:-^44}   {:-^33}\n", "", "",
                     " paper's set-up: ICP frame to frame ", " hazmap: frame to local map ");
  s += fmt::format("{:<44} {:>9}   {:>9} {:>8} {:>8} {:>9} {:>6}", "Method", "paper [m]", "map [m]",
                   "p95 [m]", "ATE [m]", "frames/s", "loops");
  if (both) s += fmt::format("   {:>9} {:>8} {:>8} {:>5}", "map [m]", "ATE [m]", "frames/s", "loops");
  s += "\n";
  for (std::size_t i = 0; i < report.rows.size(); ++i) {
    const DemoRow& r = report.rows[i];
    s += fmt::format("{:<44} {:>9.3f}   {:>9.3f} {:>8.3f} {:>8.3f} {:>9} {:>6}", paperRowTitle(r.method),
                     paperMapError(r.method), r.map_error_m, r.map_error_p95_m, r.ate_m, rate(r), r.loops);
    if (both) {
      const DemoRow& m = report.map_rows[i];
      s += fmt::format("   {:>9.3f} {:>8.3f} {:>8} {:>5}", m.map_error_m, m.ate_m, rate(m), m.loops);
    }
    s += "\n";
  }
  for (const DemoRow& r : report.camera_rows)
    s += fmt::format("{:<44} {:>9}   {:>9.3f} {:>8.3f} {:>8.3f} {:>9} {:>6}\n",
                     r.method == SlamMethod::PropertyIcp ? "Proposed ICP, camera labels" : "Proposed ICP + PGO, camera labels", "", r.map_error_m, r.map_error_p95_m,
                     r.ate_m, rate(r), r.loops);
  return s;
}

namespace {

// 1. The simulated sequence: the paper's experiment with its fixed noise defaults (and the
//    thermal and NIR cameras when camera labels are asked for: heat and water, the classes the
//    simulator's labels carry).
sim::SimulationSummary simulate(const DemoConfig& config, const std::filesystem::path& seq_dir, std::ostream& out) {
  const sim::SimulatorConfig sim_config = demoSimulatorConfig(config);
  out << "Simulating '" << config.scenario << "' (seed " << config.seed << ") into " << seq_dir.string();
  for (const auto& setting : config.simulator_settings) out << " " << setting;
  out << " ..." << std::endl;
  const sim::SimulationSummary sim = sim::writeSimulation(sim_config, seq_dir, /*overwrite=*/true);
  out << fmt::format("  {} frames, {:.1f} m route, odometry drift mean {:.2f} m / final {:.2f} m, {:.1f} s\n",
                     sim.frames, sim.route_length, sim.drift.mean_position_error,
                     sim.drift.final_position_error, sim.total_seconds);
  return sim;
}

// The maps' top-down view: the ceiling clipped 1.5 m above the route's mean height.
TopDownConfig topDownView(const Sequence& sequence) {
  TopDownConfig top;
  if (const auto& poses = sequence.groundTruth() ? sequence.groundTruth() : sequence.odometry()) {
    double z = 0;
    for (const auto& p : poses->poses) z += p.translation().z();
    top.clip_above = z / static_cast<double>(poses->poses.size()) + 1.5;  // drop the ceiling
  }
  top.draw_hazard_labels = false;
  top.cell_size = OutputConfig{}.map.voxel_size;  // cells fill their footprint: no speckle
  return top;
}

// One tracking mode of the demo: where its outputs go and how its montage is titled.
struct DemoPass {
  OdometryMode mode;
  std::filesystem::path dir;
  std::string png, title;
};

DemoRow rowOf(SlamMethod method, OdometryMode mode, const RunSummary& summary, const SlamResult& result) {
  DemoRow row;
  row.method = method;
  row.tracking = mode;
  row.map_error_m = summary.map_error ? summary.map_error->point.mean : 0.0;
  row.map_error_p95_m = summary.map_error ? summary.map_error->point.p95 : 0.0;
  row.ate_m = summary.trajectory ? summary.trajectory->ape.translation.rmse : 0.0;
  row.frames_per_s = result.framesPerSecond();
  row.loops = result.loops.size();
  for (const auto& f : result.frames) row.fallbacks += (usesIcp(method) && f.index > 0 && !f.icp_used);
  if (summary.edge_nees) {
    row.nees_odometry = summary.edge_nees->odometry.mean;
    row.nees_loop = summary.edge_nees->loop.mean;
    row.odometry_edges = summary.edge_nees->odometry.count;
    row.loop_edges = summary.edge_nees->loop.count;
  }
  return row;
}

// 2. Every method with one tracking mode: its run outputs and row, then the side-by-side PNG
//    and the trajectory-error plot.
std::vector<DemoRow> runMethods(const DemoConfig& config, const Sequence& sequence, const TopDownConfig& top,
                                const DemoPass& pass, std::ostream& out) {
  const std::string tag = pass.mode == OdometryMode::FrameToFrame ? "frame" : "map";
  std::vector<RunArtifacts> artifacts(config.methods.size());
  std::vector<SlamResult> results(config.methods.size());
  std::vector<DemoRow> rows;
  for (std::size_t m = 0; m < config.methods.size(); ++m) {
    const SlamMethod method = config.methods[m];
    SlamConfig slam = SlamConfig::forMethod(method);
    slam.property_icp = config.property_icp;
    for (const auto& setting : config.settings) slam.applySetting(setting);
    slam.odometry.mode = pass.mode;
    slam.threads = config.threads;
    ProgressBar bar(fmt::format("{} ({})", toString(method), tag), sequence.size(), config.progress ? -1 : 0);
    results[m] = runSlam(sequence, slam, [&](std::size_t done, std::size_t) { bar.update(done); });
    bar.finish();
    const RunSummary summary =
        writeRunOutputs(sequence, results[m], slam, demoRunOutputs(), pass.dir / toString(method), &artifacts[m]);
    rows.push_back(rowOf(method, pass.mode, summary, results[m]));
    const DemoRow& row = rows.back();
    out << fmt::format("  {:<18} {:<5} map error {:.3f} m, ATE {:.3f} m, {} frames/s, {} loops\n",
                       toString(method), tag, row.map_error_m, row.ate_m, rate(row), row.loops);
  }
  std::vector<MapPanel> panels;
  for (std::size_t m = 0; m < config.methods.size(); ++m)
    panels.push_back({fmt::format("{} - map error {:.3f} m", toString(config.methods[m]), rows[m].map_error_m),
                      &artifacts[m].map, positionsOf(results[m].estimate), artifacts[m].hazards});
  MontageConfig montage;
  montage.title = pass.title;
  writePng(config.out_dir / pass.png, renderMapMontage(panels, sequence.classTable(), top, montage));
  if (sequence.groundTruth())
    writeMethodErrorPlot(config.out_dir / (tag == "map" ? "trajectory_error_frame_to_map.png" : "trajectory_error.png"),
                         *sequence.groundTruth(), results, "Trajectory error vs distance travelled (" + tag + " tracking)");
  return rows;
}

}  // namespace

// 3. table2.json: per method, the paper's set-up, frame to map and camera labels (when run).
std::string table2Json(const DemoReport& report) {
  nlohmann::json table = nlohmann::json::object();
  for (const DemoRow& r : report.rows) table[toString(r.method)] = rowJson(r);
  if (!report.map_rows.empty()) {
    nlohmann::json f2m = nlohmann::json::object();
    for (const DemoRow& r : report.map_rows) f2m[toString(r.method)] = rowJson(r);
    table["frame_to_map"] = f2m;
  }
  if (!report.camera_rows.empty()) {
    nlohmann::json cam = nlohmann::json::object();
    for (const DemoRow& r : report.camera_rows) cam[toString(r.method)] = rowJson(r);
    cam["heat_precision"] = report.camera_heat_precision;
    cam["heat_recall"] = report.camera_heat_recall;
    table["camera_labels"] = cam;
  }
  return table.dump(2);
}

DemoReport runDemo(const DemoConfig& config, std::ostream& out) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  std::error_code ec;
  std::filesystem::create_directories(config.out_dir, ec);
  if (ec) fail(config.out_dir.string(), "cannot create demo folder: " + ec.message());

  DemoReport report;
  const auto seq_dir = config.out_dir / "sequence";
  const sim::SimulationSummary sim = simulate(config, seq_dir, out);
  report.frames = sim.frames;
  report.route_length_m = sim.route_length;
  report.simulate_seconds = sim.total_seconds;

  const Sequence sequence = Sequence::open(seq_dir);
  const TopDownConfig top = topDownView(sequence);
  report.rows = runMethods(config, sequence, top,
                           {OdometryMode::FrameToFrame, config.out_dir, "maps_side_by_side.png",
                            "hazmap demo: Table 2's five methods, the paper's set-up (heat red, water blue)"},
                           out);
  if (config.camera_labels) runCameraLabelRows(config, seq_dir, report, out);
  if (config.frame_to_map)
    report.map_rows = runMethods(config, sequence, top,
                                 {OdometryMode::FrameToMap, config.out_dir / "frame-to-map",
                                  "maps_side_by_side_frame_to_map.png",
                                  "hazmap demo: the five methods with frame-to-map tracking (heat red, water blue)"},
                                 out);
  writeTextAtomically(config.out_dir / "table2.json", table2Json(report) + "\n");
  writeDemoIndex(config.out_dir, report, config.frame_to_map);
  report.total_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  out << "\n" << formatTable2(report);
  out << fmt::format("\nWrote {} (sequence/, index.html, one folder per method with viewer.html{}, maps_side_by_side*.png, trajectory_error*.png, table2.json) in {:.1f} s\n",
                     config.out_dir.string(), config.frame_to_map ? ", frame-to-map/" : "", report.total_seconds);
  return report;
}

}  // namespace hazmap
