#pragma once
// Shared helpers of the _hazmap module: numpy views of LabeledCloud channels, pose arrays, the
// class-table argument, and one registration function per binding file.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/io/trajectory.hpp"

namespace hazmap::python {

namespace py = pybind11;

/// "default", "semantic-kitti", a YAML path, or None (= default).
ClassTable classTableArg(const py::handle& classes);

/// A cloud argument as every entry point takes it: a hazmap.LabeledCloud (used in place, no copy)
/// or a numpy array (N,3) x y z / (N,4) x y z class of floats (copied in). Anything else, or a
/// non-finite coordinate, or a class that is not a whole number 0-65535, throws hazmap::Error
/// naming `where` (the argument).
class CloudArg {
 public:
  CloudArg(const py::handle& value, const std::string& where);
  const LabeledCloud& get() const { return borrowed_ ? *borrowed_ : owned_; }

 private:
  const LabeledCloud* borrowed_ = nullptr;  ///< the Python object outlives the call
  LabeledCloud owned_;
};
/// True when `value` can be a cloud argument (a LabeledCloud or a numpy array, checked later).
bool isCloudLike(const py::handle& value);

Eigen::Isometry3d isometryFrom(const Eigen::Matrix4d& m, const std::string& where);
/// (N,4,4) float64 array of the poses.
template <typename Poses>
py::array_t<double> posesArray(const Poses& poses) {
  py::array_t<double> out({static_cast<py::ssize_t>(poses.size()), py::ssize_t{4}, py::ssize_t{4}});
  auto a = out.mutable_unchecked<3>();
  for (std::size_t i = 0; i < poses.size(); ++i)
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) a(static_cast<py::ssize_t>(i), r, c) = poses[i].matrix()(r, c);
  return out;
}
/// A trajectory from an (N,4,4) array (stamps = frame index unless given).
Trajectory trajectoryFrom(const py::array_t<double, py::array::c_style | py::array::forcecast>& poses,
                          const std::string& where);

void bindClouds(py::module_& m);
void bindSources(py::module_& m);
void bindRegistration(py::module_& m);
void bindSlam(py::module_& m);
void bindEvaluation(py::module_& m);
void bindGraph(py::module_& m);
void bindConfigs(py::module_& m);

}  // namespace hazmap::python
