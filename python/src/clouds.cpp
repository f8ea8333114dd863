// LabeledCloud ↔ numpy. Reading a channel gives a view on the C++ vector (no copy: points are
// Eigen::Vector3f, 12 contiguous bytes, so (N,3) float32 with strides (12, 4)); the view keeps
// the cloud alive. Assigning a channel copies the array in.
#include <cmath>
#include <cstring>
#include <filesystem>

#include "bindings.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/cloud_file.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"

namespace hazmap::python {

ClassTable classTableArg(const py::handle& classes) {
  if (classes.is_none()) return ClassTable::defaults();
  return ClassTable::load(py::str(classes).cast<std::string>());
}

Eigen::Isometry3d isometryFrom(const Eigen::Matrix4d& m, const std::string& where) {
  if (!m.allFinite()) fail(where, "pose has a non-finite value");
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9) fail(where, "last row must be [0 0 0 1]");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.matrix() = m;
  return T;
}

Trajectory trajectoryFrom(const py::array_t<double, py::array::c_style | py::array::forcecast>& poses,
                          const std::string& where) {
  if (poses.ndim() != 3 || poses.shape(1) != 4 || poses.shape(2) != 4)
    fail(where, "poses must be an (N,4,4) array");
  Trajectory t;
  auto a = poses.unchecked<3>();
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) m(r, c) = a(i, r, c);
    t.push_back(static_cast<double>(i), isometryFrom(m, where + "[" + std::to_string(i) + "]"));
  }
  return t;
}

namespace {

std::string shapeOf(const py::array& a) {
  std::string out = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) out += (d ? ", " : "") + std::to_string(a.shape(d));
  return out + (a.ndim() == 1 ? ",)" : ")");
}

/// An (N,3) or (N,4) float array: x y z [class], as docs/python.md promises.
LabeledCloud cloudFromArray(const py::array& array, const std::string& where) {
  if (array.dtype().kind() != 'f')
    fail(where, "must be a float array (float32 or float64), got dtype " + py::str(array.dtype()).cast<std::string>());
  if (array.ndim() != 2 || (array.shape(1) != 3 && array.shape(1) != 4))
    fail(where, "must be an (N,3) array of x y z or (N,4) of x y z class, got shape " + shapeOf(array));
  const auto values = py::array_t<double, py::array::forcecast>::ensure(array);  // outlives `a`
  const auto a = values.unchecked<2>();
  const bool labelled = array.shape(1) == 4;
  LabeledCloud c;
  c.resize(static_cast<std::size_t>(a.shape(0)));
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    const Eigen::Vector3d p(a(i, 0), a(i, 1), a(i, 2));
    if (!p.allFinite()) fail(where, "point " + std::to_string(i) + " has a non-finite coordinate");
    c.points[std::size_t(i)] = p.cast<float>();
    if (!labelled) continue;
    const double cls = a(i, 3);
    if (!(cls >= 0 && cls <= 65535 && cls == std::floor(cls)))
      fail(where, "point " + std::to_string(i) + " has class " + py::str(py::float_(cls)).cast<std::string>() +
                      " (the 4th column must hold whole numbers 0-65535)");
    c.classes[std::size_t(i)] = static_cast<ClassId>(cls);
  }
  return c;
}

template <typename T>
py::object channelView(std::vector<T>& v, py::handle owner, bool present) {
  if (!present) return py::none();
  return py::array_t<T>({static_cast<py::ssize_t>(v.size())}, {static_cast<py::ssize_t>(sizeof(T))},
                        v.data(), owner);
}

template <typename T>
void setChannel(std::vector<T>& v, const py::object& value, std::size_t n, const char* name) {
  if (value.is_none()) {
    v.clear();
    return;
  }
  auto a = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(value);
  if (!a || a.ndim() != 1) fail(name, "must be a 1-D array");
  if (static_cast<std::size_t>(a.shape(0)) != n)
    fail(name, "has " + std::to_string(a.shape(0)) + " values for " + std::to_string(n) + " points");
  v.assign(a.data(), a.data() + a.shape(0));
}

void setPoints(LabeledCloud& c, const py::object& value) {
  auto a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(value);
  if (!a || a.ndim() != 2 || a.shape(1) != 3) fail("points", "must be an (N,3) array");
  const std::size_t n = static_cast<std::size_t>(a.shape(0));
  if (n != c.size()) {  // other channels cannot describe different points: unlabelled, no extras
    c.classes.assign(n, 0);
    c.intensity.clear();
    c.timestamps.clear();
    c.property.clear();
  }
  c.points.resize(n);
  if (n > 0) std::memcpy(c.points.data(), a.data(), n * 3 * sizeof(float));
}

LabeledCloud makeCloud(const py::object& points, const py::object& classes, const py::object& intensity,
                       const py::object& timestamps, const py::object& property) {
  LabeledCloud c;
  setPoints(c, points);
  if (!classes.is_none()) setChannel(c.classes, classes, c.size(), "classes");
  setChannel(c.intensity, intensity, c.size(), "intensity");
  setChannel(c.timestamps, timestamps, c.size(), "timestamps");
  setChannel(c.property, property, c.size(), "property");
  return c;
}

py::object pointsView(LabeledCloud& c, py::handle owner) {
  return py::array_t<float>({static_cast<py::ssize_t>(c.size()), py::ssize_t{3}},
                            {static_cast<py::ssize_t>(sizeof(Eigen::Vector3f)), static_cast<py::ssize_t>(sizeof(float))},
                            c.points.empty() ? nullptr : c.points.front().data(), owner);
}

}  // namespace

CloudArg::CloudArg(const py::handle& value, const std::string& where) {
  if (py::isinstance<LabeledCloud>(value)) borrowed_ = &value.cast<const LabeledCloud&>();
  else if (py::isinstance<py::array>(value)) owned_ = cloudFromArray(py::reinterpret_borrow<py::array>(value), where);
  else
    fail(where, "must be a hazmap.LabeledCloud or a numpy array (N,3) x y z / (N,4) x y z class, got " +
                    py::str(py::type::of(value).attr("__name__")).cast<std::string>());
}

bool isCloudLike(const py::handle& value) { return py::isinstance<LabeledCloud>(value) || py::isinstance<py::array>(value); }

void bindClouds(py::module_& m) {
  static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "points must be packed for the numpy view");
  py::class_<LabeledCloud>(m, "LabeledCloud",
                           "Points (N,3) float32, classes uint16, optional intensity/timestamps/property")
      .def(py::init(&makeCloud), py::arg("points"), py::arg("classes") = py::none(),
           py::arg("intensity") = py::none(), py::arg("timestamps") = py::none(), py::arg("property") = py::none())
      .def("__len__", &LabeledCloud::size)
      .def_property(
          "points", [](py::object self) { return pointsView(self.cast<LabeledCloud&>(), self); },
          [](LabeledCloud& c, const py::object& v) { setPoints(c, v); })
      .def_property(
          "classes",
          [](py::object self) { auto& c = self.cast<LabeledCloud&>(); return channelView(c.classes, self, true); },
          [](LabeledCloud& c, const py::object& v) { setChannel(c.classes, v, c.size(), "classes"); })
      .def_property(
          "intensity",
          [](py::object self) { auto& c = self.cast<LabeledCloud&>(); return channelView(c.intensity, self, !c.intensity.empty()); },
          [](LabeledCloud& c, const py::object& v) { setChannel(c.intensity, v, c.size(), "intensity"); })
      .def_property(
          "timestamps",
          [](py::object self) { auto& c = self.cast<LabeledCloud&>(); return channelView(c.timestamps, self, !c.timestamps.empty()); },
          [](LabeledCloud& c, const py::object& v) { setChannel(c.timestamps, v, c.size(), "timestamps"); })
      .def_property(
          "property",
          [](py::object self) { auto& c = self.cast<LabeledCloud&>(); return channelView(c.property, self, !c.property.empty()); },
          [](LabeledCloud& c, const py::object& v) { setChannel(c.property, v, c.size(), "property"); })
      .def("transformed", [](const LabeledCloud& c, const Eigen::Matrix4d& T) {
        return c.transformed(isometryFrom(T, "transformed"));
      })
      .def("copy", [](const LabeledCloud& c) { return LabeledCloud(c); })
      .def("__repr__", [](const LabeledCloud& c) {
        return "<hazmap.LabeledCloud " + std::to_string(c.size()) + " points>";
      });

  m.def(
      "read_cloud",
      [](const std::filesystem::path& path, const py::object& classes) {
        const ClassTable table = classTableArg(classes);
        py::gil_scoped_release release;
        return readCloud(path, table);
      },
      py::arg("path"), py::arg("classes") = py::none(),
      "Reads a KITTI .bin (+ .label), PCD or PLY file by extension");
  m.def(
      "voxel_downsample",
      [](const py::object& cloud_arg, double voxel_size, const py::object& classes) {
        const CloudArg cloud_in(cloud_arg, "cloud");
        const LabeledCloud& cloud = cloud_in.get();
        VoxelDownsampleConfig config;
        config.voxel_size = voxel_size;
        if (!(voxel_size > 0)) fail("voxel_size", "must be > 0, got " + std::to_string(voxel_size));
        const ClassTable table = classTableArg(classes);
        py::gil_scoped_release release;
        return voxelDownsample(cloud, config, table);
      },
      py::arg("cloud"), py::arg("voxel_size"), py::arg("classes") = py::none(),
      "Voxel grid averaging that keeps classes (majority vote)");
  m.def(
      "write_cloud",
      [](const std::filesystem::path& path, const py::object& cloud_arg, const py::object& classes) {
        const CloudArg cloud_in(cloud_arg, "cloud");
        const LabeledCloud& cloud = cloud_in.get();
        const ClassTable table = classTableArg(classes);
        py::gil_scoped_release release;
        writeCloud(path, cloud, table);
      },
      py::arg("path"), py::arg("cloud"), py::arg("classes") = py::none(),
      "Writes .bin (+ .label), .pcd or .ply by extension, atomically");
}

}  // namespace hazmap::python
