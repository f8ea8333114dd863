#pragma once
// One description per config struct — key, member, allowed range or choices, doc — from which
// everything else follows: reading YAML (errors name the file and the key, unknown keys are
// errors with the closest valid key suggested), validation, writing YAML and JSON, the defaults
// printed by `hazmap config --dump-defaults` and docs/configuration.md, and introspection for
// bindings. Defaults are NOT written here: they are the struct's default member initialisers,
// read from a default-constructed struct, so the documentation cannot drift from the code.
//
// A struct S gets its table by defining `const ConfigFields<S>& configFields(ConfigTag<S>)`
// (declared next to the struct, defined in its *_config.cpp), e.g.
//   static const ConfigFields<LocalMapConfig> f = ConfigFields<LocalMapConfig>()
//       .number("voxel_size", &LocalMapConfig::voxel_size, positive(), "m, map voxel edge")
//       .integer("max_points_per_voxel", &LocalMapConfig::max_points_per_voxel, atLeast(1), "...");
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "hazmap/core/config_fwd.hpp"
#include "hazmap/core/error.hpp"

namespace hazmap {

/// Allowed values of a number (always finite).
struct Range {
  std::optional<double> lo, hi;
  bool lo_open = false, hi_open = false;
  bool contains(double v) const;
  std::string text() const;  ///< "> 0", ">= 1", "[0, 1]", "(0, 1]", "any number"
};
Range positive();                          ///< > 0
Range nonNegative();                       ///< >= 0
Range atLeast(double lo);                  ///< >= lo
Range atMost(double hi);                   ///< <= hi
Range closed(double lo, double hi);        ///< [lo, hi]
Range openClosed(double lo, double hi);    ///< (lo, hi]
Range closedOpen(double lo, double hi);    ///< [lo, hi)
Range anyNumber();

/// What a field is: for documentation, `--help` and bindings.
struct FieldInfo {
  std::string name;
  std::string type;     ///< number, integer, bool, string, choice, map, section
  std::string doc;
  std::string allowed;  ///< the range or the choices, as text
  nlohmann::json default_value;     ///< sections: an object with their fields' defaults
  std::vector<FieldInfo> children;  ///< sections only
};

/// Where a value came from: the file (may be empty) and the dotted key path. Errors read
/// "FILE: odometry.registration.max_iterations: must be >= 1, got 0".
struct ConfigPlace {
  std::string file;
  std::string path;
  ConfigPlace child(const std::string& key) const {
    return {file, path.empty() ? key : path + "." + key};
  }
  [[noreturn]] void fail(const std::string& what) const;
};

namespace config_detail {
double readNumber(const YAML::Node& node, const ConfigPlace& place);
long long readInteger(const YAML::Node& node, const ConfigPlace& place);
std::uint64_t readUnsigned(const YAML::Node& node, const ConfigPlace& place);
bool readBool(const YAML::Node& node, const ConfigPlace& place);
std::string readString(const YAML::Node& node, const ConfigPlace& place);
void checkRange(double value, const Range& range, const ConfigPlace& place);
/// "unknown key 'x'" plus " (did you mean 'y'?)" when a valid key is close.
[[noreturn]] void unknownKey(const std::string& key, const std::vector<std::string>& valid,
                             const ConfigPlace& place);
void requireMapping(const YAML::Node& node, const ConfigPlace& place);
std::string formatNumber(double v);  ///< shortest text that reads back to the same double
}  // namespace config_detail

/// Parses YAML text; errors name `where` and the line.
YAML::Node parseConfigYaml(const std::string& text, const std::string& where);
/// JSON (objects, scalars, arrays) as block YAML, numbers in their shortest round-trip form.
std::string jsonToYaml(const nlohmann::json& value);

template <typename S>
class ConfigFields {
 public:
  struct Field {
    FieldInfo info;  ///< default_value is filled by describe()
    std::function<void(S&, const YAML::Node&, const ConfigPlace&)> read;
    std::function<nlohmann::json(const S&)> write;
    std::function<void(const S&, const ConfigPlace&)> check;
    std::function<std::vector<FieldInfo>(const S&)> children;  ///< sections only
    std::function<bool(const S&)> written;                     ///< null = always written
    bool read_first = false;  ///< presets: read before the mapping's other keys
  };
  struct Rule {
    std::string key;
    std::function<bool(const S&)> ok;
    std::string what;
  };

  explicit ConfigFields(std::string doc = {}) : doc_(std::move(doc)) {}

  ConfigFields& number(const char* name, double S::*member, Range range, const char* doc) {
    return add({name, "number", doc, range.text(), {}, {}},
               [=](S& s, const YAML::Node& n, const ConfigPlace& p) { s.*member = config_detail::readNumber(n, p); },
               [=](const S& s) { return nlohmann::json(s.*member); },
               [=](const S& s, const ConfigPlace& p) { config_detail::checkRange(s.*member, range, p); });
  }
  template <typename T>
  ConfigFields& integer(const char* name, T S::*member, Range range, const char* doc) {
    static_assert(std::is_integral_v<T>);
    return add({name, "integer", doc, range.text(), {}, {}},
               [=](S& s, const YAML::Node& n, const ConfigPlace& p) {
                 if constexpr (std::is_same_v<T, std::uint64_t> || std::is_same_v<T, unsigned long>) {
                   s.*member = static_cast<T>(config_detail::readUnsigned(n, p));
                 } else {
                   const long long v = config_detail::readInteger(n, p);
                   if (std::is_unsigned_v<T> && v < 0) p.fail("must be >= 0, got " + std::to_string(v));
                   if (v < static_cast<long long>(std::numeric_limits<T>::min()) ||
                       static_cast<unsigned long long>(v) > static_cast<unsigned long long>(std::numeric_limits<T>::max()))
                     p.fail("out of range: " + std::to_string(v));
                   s.*member = static_cast<T>(v);
                 }
               },
               [=](const S& s) { return nlohmann::json(s.*member); },
               [=](const S& s, const ConfigPlace& p) {
                 config_detail::checkRange(static_cast<double>(s.*member), range, p);
               });
  }
  ConfigFields& flag(const char* name, bool S::*member, const char* doc) {
    return add({name, "bool", doc, "true | false", {}, {}},
               [=](S& s, const YAML::Node& n, const ConfigPlace& p) { s.*member = config_detail::readBool(n, p); },
               [=](const S& s) { return nlohmann::json(s.*member); }, nullptr);
  }
  ConfigFields& text(const char* name, std::string S::*member, const char* doc) {
    return add({name, "string", doc, "text", {}, {}},
               [=](S& s, const YAML::Node& n, const ConfigPlace& p) { s.*member = config_detail::readString(n, p); },
               [=](const S& s) { return nlohmann::json(s.*member); }, nullptr);
  }
  /// An enum spelled by name; the first name of a value is the one written, later ones are
  /// accepted aliases.
  template <typename E>
  ConfigFields& choice(const char* name, E S::*member, std::vector<std::pair<std::string, E>> names,
                       const char* doc) {
    std::string allowed;
    std::vector<E> seen;
    for (const auto& [n, e] : names)
      if (std::find(seen.begin(), seen.end(), e) == seen.end()) {
        seen.push_back(e);
        allowed += (allowed.empty() ? "" : " | ") + n;
      }
    return add({name, "choice", doc, allowed, {}, {}},
               [=](S& s, const YAML::Node& n, const ConfigPlace& p) {
                 const std::string t = config_detail::readString(n, p);
                 for (const auto& [k, e] : names)
                   if (k == t) {
                     s.*member = e;
                     return;
                   }
                 p.fail("must be one of " + allowed + ", got '" + t + "'");
               },
               [=](const S& s) {
                 for (const auto& [k, e] : names)
                   if (e == s.*member) return nlohmann::json(k);
                 return nlohmann::json(nullptr);
               },
               nullptr);
  }
  /// A named preset stored in `member`: reading it applies the preset's function to the whole
  /// struct before the mapping's other keys are read (whatever their order), so keys given next
  /// to it override it.
  ConfigFields& preset(const char* name, std::string S::*member,
                       std::vector<std::pair<std::string, std::function<void(S&)>>> presets, const char* doc) {
    std::string allowed;
    for (const auto& p : presets) allowed += (allowed.empty() ? "" : " | ") + p.first;
    add({name, "choice", doc, allowed, {}, {}},
        [=](S& s, const YAML::Node& n, const ConfigPlace& p) {
          const std::string t = config_detail::readString(n, p);
          for (const auto& [k, apply] : presets)
            if (k == t) {
              if (apply) apply(s);
              s.*member = k;
              return;
            }
          p.fail("must be one of " + allowed + ", got '" + t + "'");
        },
        [=](const S& s) { return nlohmann::json(s.*member); }, nullptr);
    fields_.back().read_first = true;
    return *this;
  }
  /// A mapping of names to numbers (e.g. class name → search radius).
  ConfigFields& numberMap(const char* name, std::map<std::string, double> S::*member, Range range,
                          const char* doc) {
    return add({name, "map", doc, "name: number (" + range.text() + ")", {}, {}},
               [=](S& s, const YAML::Node& n, const ConfigPlace& p) {
                 if (!n || n.IsNull()) return;
                 config_detail::requireMapping(n, p);
                 for (const auto& kv : n) {
                   const std::string key = config_detail::readString(kv.first, p);
                   (s.*member)[key] = config_detail::readNumber(kv.second, p.child(key));
                 }
               },
               [=](const S& s) {
                 nlohmann::json j = nlohmann::json::object();
                 for (const auto& [k, v] : s.*member) j[k] = v;
                 return j;
               },
               [=](const S& s, const ConfigPlace& p) {
                 for (const auto& [k, v] : s.*member) config_detail::checkRange(v, range, p.child(k));
               });
  }
  /// A nested struct with its own table.
  template <typename C>
  ConfigFields& section(const char* name, C S::*member, const char* doc) {
    return section<C>(name, [member](S& s) -> C& { return s.*member; }, configFields(ConfigTag<C>{}), doc);
  }
  /// A section whose fields live wherever `get` says (e.g. in S itself, grouped under a key).
  template <typename C, typename Get>
  ConfigFields& section(const char* name, Get get, const ConfigFields<C>& fields, const char* doc) {
    const ConfigFields<C>* f = &fields;
    const auto cget = [get](const S& s) -> const C& { return get(const_cast<S&>(s)); };
    // The struct's own description, after what this place adds (if anything).
    const std::string full_doc = std::string(doc).empty() ? fields.doc()
                                 : fields.doc().empty()   ? std::string(doc)
                                                          : std::string(doc) + ". " + fields.doc();
    Field field{{name, "section", full_doc, "", {}, {}},
                [f, get](S& s, const YAML::Node& n, const ConfigPlace& p) { f->read(get(s), n, p); },
                [f, cget](const S& s) { return f->write(cget(s)); },
                [f, cget](const S& s, const ConfigPlace& p) { f->check(cget(s), p); },
                [f, cget](const S& s) { return f->describe(cget(s)); },
                nullptr};
    fields_.push_back(std::move(field));
    return *this;
  }
  /// A field with its own reading, writing and checking (e.g. a list of sub-configs); `info`
  /// documents it (name, type, doc, allowed).
  ConfigFields& custom(FieldInfo info, std::function<void(S&, const YAML::Node&, const ConfigPlace&)> read,
                       std::function<nlohmann::json(const S&)> write,
                       std::function<void(const S&, const ConfigPlace&)> check) {
    return add(std::move(info), std::move(read), std::move(write), std::move(check));
  }
  /// A check across fields; `key` is the field named in the error.
  ConfigFields& rule(const char* key, std::function<bool(const S&)> ok, std::string what) {
    rules_.push_back({key, std::move(ok), std::move(what)});
    return *this;
  }
  /// Keys accepted and dropped (informational output that shares a file with settings).
  ConfigFields& ignore(const char* key) {
    ignored_.push_back(key);
    return *this;
  }
  /// The last field added is written only when `pred` holds (alternatives such as a built-in
  /// scene name versus a scene file).
  ConfigFields& writeIf(std::function<bool(const S&)> pred) {
    fields_.back().written = std::move(pred);
    return *this;
  }

  /// Reads a mapping over `s` (absent keys keep their values). Does not validate.
  void read(S& s, const YAML::Node& node, const ConfigPlace& place) const {
    if (!node || node.IsNull()) return;
    config_detail::requireMapping(node, place);
    for (const bool first_pass : {true, false})
      for (const auto& kv : node) {
        const std::string key = config_detail::readString(kv.first, place);
        if (std::find(ignored_.begin(), ignored_.end(), key) != ignored_.end()) continue;
        const Field* f = find(key);
        if (!f) config_detail::unknownKey(key, names(), place);
        if (f->read_first == first_pass) f->read(s, kv.second, place.child(key));
      }
  }
  /// Throws hazmap::Error naming the first field out of its range.
  void check(const S& s, const ConfigPlace& place) const {
    for (const auto& f : fields_)
      if (f.check) f.check(s, place.child(f.info.name));
    for (const auto& r : rules_)
      if (!r.ok(s)) place.child(r.key).fail(r.what);
  }
  nlohmann::json write(const S& s) const {
    nlohmann::json j = nlohmann::json::object();
    for (const auto& f : fields_)
      if (!f.written || f.written(s)) j[f.info.name] = f.write(s);
    return j;
  }
  std::vector<FieldInfo> describe(const S& defaults) const {
    std::vector<FieldInfo> out;
    for (const auto& f : fields_) {
      FieldInfo info = f.info;
      info.default_value = f.write(defaults);
      if (f.children) info.children = f.children(defaults);
      out.push_back(std::move(info));
    }
    return out;
  }
  const std::vector<Field>& fields() const { return fields_; }
  const Field* find(const std::string& key) const {
    for (const auto& f : fields_)
      if (f.info.name == key) return &f;
    return nullptr;
  }
  std::vector<std::string> names() const {
    std::vector<std::string> n;
    for (const auto& f : fields_) n.push_back(f.info.name);
    return n;
  }
  const std::string& doc() const { return doc_; }

 private:
  ConfigFields& add(FieldInfo info, std::function<void(S&, const YAML::Node&, const ConfigPlace&)> read,
                    std::function<nlohmann::json(const S&)> write,
                    std::function<void(const S&, const ConfigPlace&)> check) {
    fields_.push_back({std::move(info), std::move(read), std::move(write), std::move(check), nullptr, nullptr});
    return *this;
  }
  std::string doc_;
  std::vector<Field> fields_;
  std::vector<Rule> rules_;
  std::vector<std::string> ignored_;
};

template <typename S>
const ConfigFields<S>& fieldsOf() {
  return configFields(ConfigTag<S>{});
}

/// Throws hazmap::Error("<path>.<key>: <what>") for the first invalid value.
template <typename S>
void validateConfig(const S& config, const std::string& section) {
  fieldsOf<S>().check(config, ConfigPlace{"", section});
}

/// Reads `node` over `base` and validates; errors name `place`.
template <typename S>
S readConfig(const YAML::Node& node, const ConfigPlace& place, S base) {
  fieldsOf<S>().read(base, node, place);
  fieldsOf<S>().check(base, place);
  return base;
}

/// A config from YAML text: the settings at top level or under a `section:` key (so one file
/// with several sections serves every stage). Validated; errors name `where` and the key.
template <typename S>
S configFromYaml(const std::string& yaml, const std::string& where, const std::string& section, S base) {
  YAML::Node root = parseConfigYaml(yaml, where);
  if (!section.empty() && root && root.IsMap() && root[section] && !fieldsOf<S>().find(section))
    root = root[section];
  return readConfig(root, ConfigPlace{where, section}, std::move(base));
}

template <typename S>
nlohmann::json configToJson(const S& config) {
  return fieldsOf<S>().write(config);
}

/// YAML of every field; under a `section:` key when one is given.
template <typename S>
std::string configToYaml(const S& config, const std::string& section = {}) {
  nlohmann::json j = configToJson(config);
  if (!section.empty()) j = nlohmann::json{{section, std::move(j)}};
  return jsonToYaml(j);
}

template <typename S>
std::vector<FieldInfo> describeConfig(const S& defaults = S{}) {
  return fieldsOf<S>().describe(defaults);
}

/// Applies one `section.key=value` override (value in YAML syntax) and validates.
template <typename S>
void applyConfigSetting(S& config, const std::string& assignment, const std::string& where = "--set") {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) fail(where, "expected KEY=VALUE, got '" + assignment + "'");
  YAML::Node node = parseConfigYaml(assignment.substr(eq + 1), where);
  std::string key = assignment.substr(0, eq);
  for (auto dot = key.rfind('.'); dot != std::string::npos; dot = key.rfind('.')) {
    YAML::Node parent(YAML::NodeType::Map);
    parent[key.substr(dot + 1)] = node;
    node = parent;
    key.resize(dot);
  }
  YAML::Node top(YAML::NodeType::Map);
  top[key] = node;
  config = readConfig(top, ConfigPlace{where, ""}, config);
}

}  // namespace hazmap
