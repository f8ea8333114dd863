// register() and Odometry: the C++ calls run without the GIL.
#include <chrono>

#include "bindings.hpp"
#include "config_bridge.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/registration/registration.hpp"

namespace hazmap::python {

namespace {

Eigen::Matrix4d matrixOf(const Eigen::Isometry3d& T) { return T.matrix(); }

std::optional<Eigen::Isometry3d> optionalIsometry(const py::object& value, const std::string& where) {
  if (value.is_none()) return std::nullopt;
  return isometryFrom(value.cast<Eigen::Matrix4d>(), where);
}

py::dict frameDict(const OdometryFrame& f) {
  py::dict d;
  d["index"] = f.index;
  d["stamp"] = f.stamp;
  d["pose"] = matrixOf(f.pose);
  d["increment"] = matrixOf(f.increment);
  d["guess"] = matrixOf(f.guess);
  d["covariance"] = Matrix6d(f.covariance);
  d["status"] = toString(f.status);
  d["reason"] = f.reason;
  d["wheel_guess"] = f.wheel_guess;
  d["fitness"] = f.registration.fitness;
  d["rmse"] = f.registration.inlier_rmse;
  d["iterations"] = f.registration.iterations;
  d["labels_used"] = f.registration.labels_used;
  d["scan_points"] = f.scan_points;
  d["source_points"] = f.source_points;
  d["map_points"] = f.map_points;
  d["total_ms"] = f.total_ms;
  return d;
}

}  // namespace

void bindRegistration(py::module_& m) {
  py::class_<RegistrationResult>(m, "RegistrationResult")
      .def_property_readonly("transform", [](const RegistrationResult& r) { return matrixOf(r.transform); },
                             "4x4, target ← source")
      .def_readonly("covariance", &RegistrationResult::covariance, "6x6, translation first")
      .def_readonly("fitness", &RegistrationResult::fitness)
      .def_readonly("rmse", &RegistrationResult::inlier_rmse)
      .def_readonly("iterations", &RegistrationResult::iterations)
      .def_readonly("converged", &RegistrationResult::converged)
      .def_readonly("labels_used", &RegistrationResult::labels_used)
      .def_readonly("label_agreement", &RegistrationResult::label_agreement)
      .def_readonly("reason", &RegistrationResult::reason)
      .def("__repr__", [](const RegistrationResult& r) {
        return "<hazmap.RegistrationResult fitness=" + std::to_string(r.fitness) +
               " rmse=" + std::to_string(r.inlier_rmse) + " iterations=" + std::to_string(r.iterations) +
               (r.converged ? " converged>" : " not converged>");
      });

  m.def(
      "register",
      [](const py::object& source_arg, const py::object& target_arg, const py::object& init, const py::object& config,
         const py::object& classes) {
        const CloudArg source(source_arg, "source"), target(target_arg, "target");
        const RegistrationConfig cfg = configFrom(config, RegistrationConfig{}, "registration");
        const Eigen::Isometry3d guess = optionalIsometry(init, "init").value_or(Eigen::Isometry3d::Identity());
        const ClassTable table = classTableArg(classes);
        py::gil_scoped_release release;
        return registerClouds(source.get(), target.get(), guess, table, cfg);
      },
      py::arg("source"), py::arg("target"), py::arg("init") = py::none(), py::arg("config") = py::none(),
      py::arg("classes") = py::none(),
      "Property-aware ICP of source onto target (clouds: LabeledCloud or (N,3)/(N,4) float array; "
      "config: the YAML registration: keys)");

  // The peer of bench/python_overhead.py: the same C++ call, timed in C++ around the call only.
  m.def("_time_register", [](const py::object& source_arg, const py::object& target_arg, const py::object& config) {
    const CloudArg source_in(source_arg, "source"), target_in(target_arg, "target");
    const LabeledCloud &source = source_in.get(), &target = target_in.get();
    const RegistrationConfig cfg = configFrom(config, RegistrationConfig{}, "registration");
    const ClassTable table = ClassTable::defaults();
    py::gil_scoped_release release;
    const auto t = std::chrono::steady_clock::now();
    const RegistrationResult r = registerClouds(source, target, Eigen::Isometry3d::Identity(), table, cfg);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    if (!r.converged && r.iterations == 0) fail("_time_register", r.reason);
    return seconds;
  });

  py::class_<Odometry>(m, "Odometry", "Scan-to-scan / scan-to-local-map tracking (config: the YAML odometry: keys)")
      .def(py::init([](const py::object& config, const py::object& classes, const py::object& initial_pose) {
             const OdometryConfig cfg = configFrom(config, OdometryConfig::defaults(), "odometry");
             const auto start = optionalIsometry(initial_pose, "initial_pose").value_or(Eigen::Isometry3d::Identity());
             return std::make_unique<Odometry>(classTableArg(classes), cfg, start);
           }),
           py::arg("config") = py::none(), py::arg("classes") = py::none(), py::arg("initial_pose") = py::none())
      .def(
          "add_frame",
          [](Odometry& o, const py::object& cloud_arg, const py::object& wheel_increment, double stamp) {
            const CloudArg cloud(cloud_arg, "cloud");
            const auto wheel = optionalIsometry(wheel_increment, "wheel_increment");
            const OdometryFrame* f = nullptr;
            {
              py::gil_scoped_release release;
              f = &o.addFrame(cloud.get(), wheel, stamp);
            }
            return frameDict(*f);
          },
          py::arg("cloud"), py::arg("wheel_increment") = py::none(), py::arg("stamp") = -1.0)
      .def_property_readonly("poses", [](const Odometry& o) { return posesArray(o.trajectory().poses); })
      .def("__len__", [](const Odometry& o) { return o.frames().size(); });
}

}  // namespace hazmap::python
