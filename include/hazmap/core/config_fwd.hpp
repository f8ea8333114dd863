#pragma once
// Forward declarations of the config mechanism (core/config_fields.hpp), for the headers that
// declare a config struct's field table without pulling in YAML and JSON.

namespace hazmap {

template <typename S>
class ConfigFields;

/// Selects a config struct's field table by overload: `configFields(ConfigTag<S>{})`.
template <typename S>
struct ConfigTag {};

}  // namespace hazmap
