// Scans from a sequence folder, a bag or a capture (openScanSource), iterated from Python.
#include <memory>

#include "bindings.hpp"
#include "hazmap/sources/imu_rotation.hpp"
#include "hazmap/sources/scan_source.hpp"

namespace hazmap::python {

namespace {

py::object optionalPose(const std::optional<Eigen::Isometry3d>& pose) {
  if (!pose) return py::none();
  return py::cast(Eigen::Matrix4d(pose->matrix()));
}

ScanSourceOptions sourceOptions(const std::string& lidar_topic, const std::string& odom_topic,
                                const py::object& classes, const std::string& sensor,
                                const py::object& hesai_calibration, const std::string& imu_rotation) {
  ScanSourceOptions options;
  options.lidar_topic = lidar_topic;
  options.odom_topic = odom_topic;
  options.sensor = sensor;
  if (!imu_rotation.empty()) options.imu_rotation = parseImuRotation(imu_rotation, "imu_rotation");
  // None (not an empty path: pybind turns "" into ".") means the built-in angles.
  if (!hesai_calibration.is_none()) options.hesai_calibration = hesai_calibration.cast<std::filesystem::path>();
  if (!classes.is_none()) options.class_table = classTableArg(classes);
  return options;
}

}  // namespace

void bindSources(py::module_& m) {
  py::class_<Scan>(m, "Scan", "One scan of a recording: index, stamp (s), cloud, odometry/ground_truth 4x4 or None")
      .def(py::init([](const py::object& cloud, double stamp, const py::object& odometry,
                       const py::object& ground_truth) {
             Scan s;
             s.cloud = CloudArg(cloud, "cloud").get();
             s.stamp = stamp;
             if (!odometry.is_none()) s.odometry = isometryFrom(odometry.cast<Eigen::Matrix4d>(), "odometry");
             if (!ground_truth.is_none())
               s.ground_truth = isometryFrom(ground_truth.cast<Eigen::Matrix4d>(), "ground_truth");
             return s;
           }),
           py::arg("cloud"), py::arg("stamp") = 0.0, py::arg("odometry") = py::none(),
           py::arg("ground_truth") = py::none())
      .def_readonly("index", &Scan::index)
      .def_readonly("stamp", &Scan::stamp)
      .def_readonly("cloud", &Scan::cloud)
      .def_property_readonly("odometry", [](const Scan& s) { return optionalPose(s.odometry); })
      .def_property_readonly("ground_truth", [](const Scan& s) { return optionalPose(s.ground_truth); });

  py::class_<ScanSource>(m, "ScanSource", "Iterates the scans of a sequence folder, bag or capture")
      .def("__iter__", [](py::object self) { return self; })
      .def("__next__",
           [](ScanSource& s) {
             std::optional<Scan> scan;
             {
               py::gil_scoped_release release;
               scan = s.next();
             }
             if (!scan) throw py::stop_iteration();
             return std::move(*scan);
           })
      .def("__len__",
           [](const ScanSource& s) {
             if (!s.size()) throw py::type_error("this recording does not know its length without reading it");
             return *s.size();
           })
      .def_property_readonly("size", [](const ScanSource& s) { return s.size(); })
      .def_property_readonly("description", &ScanSource::describe)
      .def("__repr__", [](const ScanSource& s) { return "<hazmap.ScanSource " + s.describe() + ">"; });

  m.def(
      "open",
      [](const std::filesystem::path& path, const std::string& lidar_topic, const std::string& odom_topic,
         const py::object& classes, const std::string& sensor, const py::object& hesai_calibration,
         const std::string& imu_rotation) {
        const ScanSourceOptions options =
            sourceOptions(lidar_topic, odom_topic, classes, sensor, hesai_calibration, imu_rotation);
        py::gil_scoped_release release;
        return openScanSource(path, options);
      },
      py::arg("path"), py::arg("lidar_topic") = "", py::arg("odom_topic") = "", py::arg("classes") = py::none(),
      py::arg("sensor") = "", py::arg("hesai_calibration") = py::none(), py::arg("imu_rotation") = "",
      "Opens a sequence folder, a bag (.bag, .mcap, rosbag2 folder) or a capture (.pcap) as a scan stream; "
      "sensor: the LiDAR model to expect (e.g. 'PandarXT32'), hesai_calibration: a Hesai angle-correction CSV, "
      "imu_rotation: R_lidar_imu of a sensor_msgs/Imu topic ('roll,pitch,yaw' deg, 'qw,qx,qy,qz', 9 or 16 numbers)");
}

}  // namespace hazmap::python
