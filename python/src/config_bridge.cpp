#include "config_bridge.hpp"

namespace hazmap::python {

std::string toJsonText(const py::handle& value) {
  return py::module_::import("json").attr("dumps")(value).cast<std::string>();
}

py::object fromJson(const nlohmann::json& value) {
  return py::module_::import("json").attr("loads")(value.dump());
}

}  // namespace hazmap::python
