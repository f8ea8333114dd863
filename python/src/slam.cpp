// hazmap.run over a recording path or a Python-fed stream, and hazmap.simulate.
#include <filesystem>
#include <random>

#include "bindings.hpp"
#include "config_bridge.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "hazmap/sim/simulator.hpp"
#include "hazmap/sources/scan_source.hpp"

namespace hazmap::python {

namespace {

/// Scans pulled from a Python iterable (hazmap.Scan objects or bare clouds — LabeledClouds or
/// (N,3)/(N,4) arrays —, whose stamp
/// is then their index) while the C++ run holds no GIL. Each scan is kept so the map's second
/// pass can replay the stream: memory grows with the recording, unlike a file source.
class PythonScanSource : public ScanSource {
 public:
  PythonScanSource(const py::object& iterable, ClassTable table) : iterator_(py::iter(iterable)), table_(std::move(table)) {}

  std::optional<Scan> next() override {
    py::gil_scoped_acquire gil;
    PyObject* item = PyIter_Next(iterator_.ptr());
    if (!item) {
      if (PyErr_Occurred()) throw py::error_already_set();
      return std::nullopt;
    }
    const py::object obj = py::reinterpret_steal<py::object>(item);
    Scan scan;
    if (py::isinstance<Scan>(obj)) {
      scan = obj.cast<Scan>();
    } else if (isCloudLike(obj)) {
      scan.cloud = CloudArg(obj, describe() + " item " + std::to_string(scans_.size())).get();
      scan.stamp = static_cast<double>(scans_.size());
    } else {
      fail(describe(), "item " + std::to_string(scans_.size()) +
                              " is neither a hazmap.Scan, a hazmap.LabeledCloud nor an (N,3)/(N,4) array");
    }
    scan.index = scans_.size();
    scans_.push_back(scan);
    return scan;
  }
  std::optional<std::size_t> size() const override { return std::nullopt; }
  const ClassTable& classTable() const override { return table_; }
  std::string describe() const override { return "Python stream"; }
  bool canReread() const override { return true; }
  LabeledCloud reread(std::size_t index) const override { return scans_.at(index).cloud; }
  const std::vector<Scan>& scans() const { return scans_; }

 private:
  py::object iterator_;
  ClassTable table_;
  std::vector<Scan> scans_;
};

/// The scans a PythonScanSource kept, streamed again (the map's second pass).
class ReplaySource : public ScanSource {
 public:
  ReplaySource(const std::vector<Scan>& scans, const ClassTable& table) : scans_(scans), table_(table) {}
  std::optional<Scan> next() override {
    if (next_ >= scans_.size()) return std::nullopt;
    return scans_[next_++];
  }
  std::optional<std::size_t> size() const override { return scans_.size(); }
  const ClassTable& classTable() const override { return table_; }
  std::string describe() const override { return "Python stream"; }
  bool canReread() const override { return true; }
  LabeledCloud reread(std::size_t index) const override { return scans_.at(index).cloud; }

 private:
  const std::vector<Scan>& scans_;
  const ClassTable& table_;
  std::size_t next_ = 0;
};

/// A fresh folder under the system temp dir, removed when the run is done (out=None).
struct TempDir {
  std::filesystem::path path;
  TempDir() {
    std::random_device rd;
    path = std::filesystem::temp_directory_path() / ("hazmap-py-" + std::to_string(rd()) + std::to_string(rd()));
    std::filesystem::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

py::dict resultDict(const SlamResult& r, const RunSummary& s) {
  py::dict d;
  d["method"] = toString(r.method);
  d["source"] = r.source;
  d["frames"] = r.frames.size();
  d["poses"] = posesArray(r.estimate.poses);
  d["stamps"] = r.estimate.stamps;
  d["tracked"] = posesArray(r.tracked.poses);
  d["odometry_only"] = posesArray(r.odometry_only.poses);
  d["loops"] = r.loops.size();
  d["keyframes"] = r.keyframes;
  d["loop_candidates"] = r.loop_candidates;
  d["frames_per_second"] = r.framesPerSecond();
  py::dict timings;
  timings["tracking_s"] = r.timings.tracking_s;
  timings["loop_s"] = r.timings.loop_s;
  timings["graph_s"] = r.timings.graph_s;
  timings["total_s"] = r.timings.total_s;
  timings["output_s"] = s.output_seconds;
  d["timings"] = timings;
  d["map_error"] = s.map_error ? fromJson(nlohmann::json::parse(toJson(*s.map_error))) : py::none();
  d["trajectory"] = s.trajectory ? fromJson(nlohmann::json::parse(toJson(*s.trajectory))) : py::none();
  d["hazards"] = s.hazards;
  d["map_cells"] = s.map_cells;
  return d;
}

/// Runs SLAM and writes the outputs (into a temporary folder when `out` is None, without the
/// PNGs) so the map error and ATE are exactly what `hazmap run` reports.
py::dict runSlamBinding(const py::object& sequence, const std::string& method, const py::object& out,
                        const py::object& config, const py::object& classes, int threads) {
  SlamConfig cfg = configFrom(config, SlamConfig::forMethod(parseSlamMethod(method)), "run config");
  cfg.threads = threads;
  std::optional<TempDir> temp;
  OutputConfig output;
  if (out.is_none()) {
    temp.emplace();
    output.write_pngs = false;
    output.write_viewer = false;
  }
  const std::filesystem::path out_dir = out.is_none() ? temp->path : std::filesystem::path(py::str(out).cast<std::string>());
  SlamResult result;
  RunSummary summary;
  const bool is_path = py::isinstance<py::str>(sequence) || py::hasattr(sequence, "__fspath__");
  if (is_path) {
    const std::string path = py::str(sequence).cast<std::string>();
    ScanSourceOptions options;
    if (!classes.is_none()) options.class_table = classTableArg(classes);
    py::gil_scoped_release release;
    const auto scans = openScanSource(path, options);
    result = runSlam(*scans, cfg);
    const auto second_pass = openScanSource(path, options);
    summary = writeRunOutputs(*second_pass, result, cfg, output, out_dir);
  } else {
    PythonScanSource scans(sequence, classTableArg(classes));
    py::gil_scoped_release release;
    result = runSlam(scans, cfg);
    ReplaySource replay(scans.scans(), scans.classTable());
    summary = writeRunOutputs(replay, result, cfg, output, out_dir);
  }
  return resultDict(result, summary);
}

py::dict simulateBinding(const std::string& out, const py::object& config, bool overwrite) {
  const sim::SimulatorConfig cfg = configFrom(config, sim::SimulatorConfig{}, "simulator config");
  sim::SimulationSummary s;
  {
    py::gil_scoped_release release;
    s = sim::writeSimulation(cfg, out, overwrite);
  }
  py::dict d;
  d["frames"] = s.frames;
  d["points"] = s.points;
  d["route_length"] = s.route_length;
  d["total_seconds"] = s.total_seconds;
  d["mean_odometry_position_error"] = s.drift.mean_position_error;
  d["final_odometry_position_error"] = s.drift.final_position_error;
  d["slips"] = s.drift.slips;
  return d;
}

}  // namespace

void bindSlam(py::module_& m) {
  m.def("_run", &runSlamBinding, py::arg("sequence"), py::arg("method"), py::arg("out") = py::none(),
        py::arg("config") = py::none(), py::arg("classes") = py::none(), py::arg("threads") = 0);
  m.def("simulate", &simulateBinding, py::arg("out"), py::arg("config") = py::none(), py::arg("overwrite") = false,
        "Writes a simulated sequence folder (config: the keys of `hazmap simulate --config`)");
}

}  // namespace hazmap::python
