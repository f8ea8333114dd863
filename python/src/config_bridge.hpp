#pragma once
// Python configs go through the same field tables as the YAML (core/config_fields.hpp): a dict
// (or anything json.dumps accepts) is turned into JSON text — JSON is YAML — and read over the
// struct's defaults with readConfig, so the keys, ranges and error messages are the YAML's.
#include <pybind11/pybind11.h>

#include <string>

#include "hazmap/core/config_fields.hpp"

namespace hazmap::python {

namespace py = pybind11;

/// JSON text of a Python object (dict, list, number, …) via the json module.
std::string toJsonText(const py::handle& value);
/// A Python object from JSON (dicts, lists, numbers, strings).
py::object fromJson(const nlohmann::json& value);

/// `config` (None, a dict, or an object with to_dict()) read over `base`; errors name `where`.
template <typename S>
S configFrom(const py::handle& config, S base, const std::string& where) {
  if (config.is_none()) return base;
  py::object value = py::reinterpret_borrow<py::object>(config);
  if (py::hasattr(value, "to_dict")) value = value.attr("to_dict")();
  const std::string text = toJsonText(value);
  return readConfig(parseConfigYaml(text, where), ConfigPlace{where, ""}, std::move(base));
}

/// The struct's fields as a dict of their values (the YAML's keys and spellings).
template <typename S>
py::object configDict(const S& config) {
  return fromJson(configToJson(config));
}

}  // namespace hazmap::python
