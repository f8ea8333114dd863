// hazmap.evaluate: the numbers of `hazmap eval` (same readers, association and metrics), as a dict
// shaped like `hazmap eval --json`.

#include "bindings.hpp"
#include "config_bridge.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/eval/trajectory_metrics.hpp"

namespace hazmap::python {

namespace {

/// As `hazmap eval`: a TUM file has 8 numbers on its first data line.
bool isTumFile(const std::string& path) { return detectTrajectoryFormat(path) == TrajectoryFormat::Tum; }

bool isPath(const py::handle& v) { return py::isinstance<py::str>(v) || py::hasattr(v, "__fspath__"); }

Trajectory trajectoryArg(const py::handle& v, const std::string& where) {
  if (isPath(v)) return readTrajectoryAuto(py::str(v).cast<std::string>());
  return trajectoryFrom(py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(v), where);
}

py::object evaluateBinding(const py::object& gt_arg, const py::object& est_arg, const std::string& align,
                           double delta, const std::string& delta_unit, double max_dt) {
  const auto alignment = parseAlignment(align);
  if (!alignment) fail("align", "expected se3, sim3 or none, got '" + align + "'");
  if (delta_unit != "m" && delta_unit != "frames") fail("delta_unit", "expected m or frames, got '" + delta_unit + "'");
  const std::string gt_name = isPath(gt_arg) ? py::str(gt_arg).cast<std::string>() : "gt";
  const std::string est_name = isPath(est_arg) ? py::str(est_arg).cast<std::string>() : "est";
  Trajectory gt = trajectoryArg(gt_arg, gt_name);
  Trajectory est = trajectoryArg(est_arg, est_name);
  TrajectoryEvalConfig config;
  config.ape_alignment = *alignment;
  config.rpe.delta = delta;
  config.rpe.unit = delta_unit == "m" ? DeltaUnit::Metres : DeltaUnit::Frames;
  const bool both_tum = isPath(gt_arg) && isPath(est_arg) && isTumFile(gt_name) && isTumFile(est_name);
  std::string json;
  {
    py::gil_scoped_release release;
    checkTrajectory(gt, gt_name);
    checkTrajectory(est, est_name);
    if (both_tum) {
      std::tie(gt, est) = associateTrajectories(gt, est, max_dt);
    } else if (gt.size() != est.size()) {
      fail(est_name, "has " + std::to_string(est.size()) + " poses but the ground truth " + gt_name + " has " +
                         std::to_string(gt.size()) + " (KITTI files are compared row by row; use TUM files to match by time)");
    }
    json = toJson(evaluateTrajectory(gt, est, config));
  }
  return fromJson(nlohmann::json::parse(json));
}

}  // namespace

void bindEvaluation(py::module_& m) {
  m.def("evaluate", &evaluateBinding, py::arg("gt"), py::arg("est"), py::arg("align") = "se3",
        py::arg("delta") = 10.0, py::arg("delta_unit") = "m", py::arg("max_dt") = 0.01,
        "APE/RPE/KITTI errors of est against gt (paths or (N,4,4) arrays), as `hazmap eval --json`");
}

}  // namespace hazmap::python
