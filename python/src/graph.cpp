// hazmap.PoseGraph: g2o load/save and the Ceres optimiser.
#include "bindings.hpp"
#include "config_bridge.hpp"
#include "hazmap/graph/optimizer.hpp"
#include "hazmap/graph/pose_graph.hpp"
#include "hazmap/graph/g2o.hpp"

namespace hazmap::python {

void bindGraph(py::module_& m) {
  py::class_<PoseGraph>(m, "PoseGraph", "SE(3)/SE(2) pose graph (g2o files)")
      .def(py::init<>())
      .def_static(
          "load",
          [](const std::filesystem::path& path, bool repair_information) {
            py::gil_scoped_release release;
            return readG2o(path, nullptr, repair_information ? G2oInformation::NearestPositiveDefinite : G2oInformation::Strict);
          },
          py::arg("path"), py::arg("repair_information") = false)
      .def(
          "save",
          [](const PoseGraph& g, const std::filesystem::path& path) {
            py::gil_scoped_release release;
            writeG2o(path, g);
          },
          py::arg("path"))
      .def(
          "optimise",
          [](PoseGraph& g, const py::object& config) {
            const PoseGraphConfig cfg = configFrom(config, PoseGraphConfig{}, "graph");
            PoseGraphReport r;
            {
              py::gil_scoped_release release;
              r = optimizePoseGraph(g, cfg);
            }
            py::dict d;
            d["initial_chordal"] = r.initial_chordal;
            d["initial_geodesic"] = r.initial_geodesic;
            d["final_chordal"] = r.final_chordal;
            d["final_geodesic"] = r.final_geodesic;
            d["iterations"] = r.iterations;
            d["converged"] = r.converged;
            d["total_seconds"] = r.total_seconds;
            d["message"] = r.message;
            return d;
          },
          py::arg("config") = py::none(), "Optimises the poses in place (config: the YAML graph: keys)")
      .def_readonly("dimension", &PoseGraph::dimension)
      .def_property_readonly("poses", [](const PoseGraph& g) { return posesArray(g.poses); })
      .def_property_readonly("ids", [](const PoseGraph& g) { return g.ids; })
      .def_property_readonly("edges", [](const PoseGraph& g) { return g.edges.size(); })
      .def("__len__", [](const PoseGraph& g) { return g.poses.size(); });
}

}  // namespace hazmap::python
