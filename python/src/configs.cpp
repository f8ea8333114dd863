// Config defaults and field descriptions for Python, straight from the field tables, so the
// Python side never lists a field itself.
#include "bindings.hpp"
#include "config_bridge.hpp"
#include "hazmap/graph/optimizer.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "hazmap/registration/registration.hpp"
#include "hazmap/sim/simulator.hpp"

namespace hazmap::python {

namespace {

nlohmann::json infoJson(const FieldInfo& f) {
  nlohmann::json j{{"name", f.name}, {"type", f.type}, {"doc", f.doc}, {"allowed", f.allowed},
                   {"default", f.default_value}};
  if (!f.children.empty()) {
    j["fields"] = nlohmann::json::array();
    for (const auto& c : f.children) j["fields"].push_back(infoJson(c));
  }
  return j;
}

template <typename S>
py::object describe(const S& defaults) {
  nlohmann::json j = nlohmann::json::array();
  for (const auto& f : describeConfig(defaults)) j.push_back(infoJson(f));
  return fromJson(j);
}

/// kind → (defaults dict, field descriptions, validated dict of a given config).
template <typename S>
py::tuple kindOf(const S& defaults, const py::object& config, const std::string& where) {
  return py::make_tuple(configDict(defaults), describe(defaults), configDict(configFrom(config, defaults, where)));
}

py::tuple configInfo(const std::string& kind, const py::object& config, const std::string& method) {
  if (kind == "registration") return kindOf(RegistrationConfig{}, config, kind);
  if (kind == "odometry") return kindOf(OdometryConfig::defaults(), config, kind);
  if (kind == "run") return kindOf(SlamConfig::forMethod(parseSlamMethod(method)), config, kind);
  if (kind == "graph") return kindOf(PoseGraphConfig{}, config, kind);
  if (kind == "simulator") return kindOf(sim::SimulatorConfig{}, config, kind);
  fail("config kind", "expected registration, odometry, run, graph or simulator, got '" + kind + "'");
}

}  // namespace

void bindConfigs(py::module_& m) {
  m.def("_config_info", &configInfo, py::arg("kind"), py::arg("config") = py::none(),
        py::arg("method") = "property-icp+pgo",
        "(defaults, fields, config read over the defaults and validated) of a config kind");
}

}  // namespace hazmap::python
