#include "hazmap/core/class_table.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <vector>

#include "hazmap/core/error.hpp"

namespace hazmap {

const char* toString(PropertyKind kind) {
  switch (kind) {
    case PropertyKind::None: return "none";
    case PropertyKind::Heat: return "heat";
    case PropertyKind::Water: return "water";
    case PropertyKind::Radiation: return "radiation";
    case PropertyKind::Other: return "other";
  }
  return "other";
}

std::optional<PropertyKind> parsePropertyKind(const std::string& text) {
  for (auto k : {PropertyKind::None, PropertyKind::Heat, PropertyKind::Water,
                 PropertyKind::Radiation, PropertyKind::Other})
    if (text == toString(k)) return k;
  return std::nullopt;
}

ClassTable ClassTable::defaults() {
  ClassTable t;
  t.add({0, "none", PropertyKind::None, {160, 160, 160}, 0.0, 1.0});
  t.add({1, "heat", PropertyKind::Heat, {230, 30, 30}, 3.0, 1.0});
  t.add({2, "water", PropertyKind::Water, {30, 80, 230}, 3.0, 1.0});
  t.add({3, "radiation", PropertyKind::Radiation, {240, 210, 20}, 3.0, 1.0});
  return t;
}

ClassTable ClassTable::semanticKitti() {
  ClassTable t = defaults();
  t.mapRawLabel(80, 1);  // pole          → heat
  t.mapRawLabel(71, 2);  // trunk         → water
  t.mapRawLabel(81, 3);  // traffic-sign  → radiation
  t.unmapped_class = 0;
  return t;
}

ClassTable ClassTable::load(const std::string& name_or_path) {
  if (name_or_path.empty() || name_or_path == "default") return defaults();
  if (name_or_path == "semantic-kitti") return semanticKitti();
  return fromYamlFile(name_or_path);
}

ClassTable ClassTable::fromYamlFile(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) fail(path.string(), "cannot open class table");
  std::stringstream ss;
  ss << in.rdbuf();
  return fromYamlString(ss.str(), path.string());
}

namespace {

template <typename T>
T scalarAs(const YAML::Node& node, const std::string& where, const std::string& key) {
  try {
    return node.as<T>();
  } catch (const YAML::Exception&) {
    fail(where, "bad value for '" + key + "'");
  }
}

}  // namespace

ClassTable ClassTable::fromYamlString(const std::string& yaml, const std::string& where) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    fail(where, std::string("invalid YAML: ") + e.msg + " at line " + std::to_string(e.mark.line + 1));
  }
  if (!root.IsMap()) fail(where, "class table must be a YAML mapping with a 'classes' list");
  const YAML::Node classes = root["classes"];
  if (!classes || !classes.IsSequence() || classes.size() == 0)
    fail(where, "class table needs a non-empty 'classes' list");
  ClassTable t;
  if (root["mismatch_penalty"])
    t.mismatch_penalty = scalarAs<double>(root["mismatch_penalty"], where, "mismatch_penalty");
  if (!(t.mismatch_penalty >= 0.0) || !std::isfinite(t.mismatch_penalty))
    fail(where, "mismatch_penalty must be a finite number >= 0");
  for (const auto& c : classes) {
    if (!c.IsMap() || !c["id"] || !c["name"])
      fail(where, "each class needs at least 'id' and 'name'");
    ClassInfo info;
    const long id = scalarAs<long>(c["id"], where, "id");
    if (id < 0 || id > 65535) fail(where, "class id " + std::to_string(id) + " out of range 0..65535");
    info.id = static_cast<ClassId>(id);
    info.name = scalarAs<std::string>(c["name"], where, "name");
    if (c["kind"]) {
      const auto kind_text = scalarAs<std::string>(c["kind"], where, "kind");
      const auto kind = parsePropertyKind(kind_text);
      if (!kind) fail(where, "class '" + info.name + "': unknown kind '" + kind_text + "'");
      info.kind = *kind;
    }
    if (c["color"]) {
      const YAML::Node col = c["color"];
      if (!col.IsSequence() || col.size() != 3)
        fail(where, "class '" + info.name + "': color must be [r, g, b]");
      for (int k = 0; k < 3; ++k) {
        const int v = scalarAs<int>(col[k], where, "color");
        if (v < 0 || v > 255) fail(where, "class '" + info.name + "': color values must be 0..255");
        info.color[k] = static_cast<std::uint8_t>(v);
      }
    }
    if (c["search_radius"]) info.search_radius = scalarAs<double>(c["search_radius"], where, "search_radius");
    if (c["weight"]) info.weight = scalarAs<double>(c["weight"], where, "weight");
    if (c["whole_extent"]) info.whole_extent = scalarAs<bool>(c["whole_extent"], where, "whole_extent");
    if (t.contains(info.id)) fail(where, "class id " + std::to_string(info.id) + " defined twice");
    try {
      t.add(info);
    } catch (const Error& e) {
      fail(where, e.what());
    }
  }
  if (const YAML::Node raw = root["raw_labels"]) {
    if (!raw.IsMap()) fail(where, "'raw_labels' must map raw label ids to class ids");
    for (const auto& kv : raw) {
      const long from = scalarAs<long>(kv.first, where, "raw_labels");
      const long to = scalarAs<long>(kv.second, where, "raw_labels");
      if (from < 0 || from > 65535) fail(where, "raw label " + std::to_string(from) + " out of range");
      if (to < 0 || to > 65535 || !t.contains(static_cast<ClassId>(to)))
        fail(where, "raw label " + std::to_string(from) + " maps to unknown class " + std::to_string(to));
      t.mapRawLabel(static_cast<std::uint32_t>(from), static_cast<ClassId>(to));
    }
  }
  if (root["unmapped_class"]) {
    const long u = scalarAs<long>(root["unmapped_class"], where, "unmapped_class");
    if (u < 0 || u > 65535 || !t.contains(static_cast<ClassId>(u)))
      fail(where, "unmapped_class " + std::to_string(u) + " is not a class in the table");
    t.unmapped_class = static_cast<ClassId>(u);
  }
  // Raw labels without an entry map to unmapped_class, so it must exist (found by fuzzing).
  if (t.hasRawMapping() && !t.contains(t.unmapped_class))
    fail(where, "unmapped_class " + std::to_string(t.unmapped_class) +
                    " is not a class in the table (set 'unmapped_class' when using 'raw_labels')");
  return t;
}

std::string ClassTable::toYamlString() const {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "mismatch_penalty" << YAML::Value << mismatch_penalty;
  out << YAML::Key << "classes" << YAML::Value << YAML::BeginSeq;
  for (const auto& [id, c] : classes_) {
    out << YAML::BeginMap << YAML::Key << "id" << YAML::Value << id;
    out << YAML::Key << "name" << YAML::Value << c.name;
    out << YAML::Key << "kind" << YAML::Value << toString(c.kind);
    out << YAML::Key << "color" << YAML::Value << YAML::Flow << YAML::BeginSeq
        << int(c.color[0]) << int(c.color[1]) << int(c.color[2]) << YAML::EndSeq;
    out << YAML::Key << "search_radius" << YAML::Value << c.search_radius;
    out << YAML::Key << "weight" << YAML::Value << c.weight;
    if (!c.whole_extent) out << YAML::Key << "whole_extent" << YAML::Value << false;  // older tables stay as they were
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (!raw_to_class_.empty()) {
    out << YAML::Key << "raw_labels" << YAML::Value << YAML::BeginMap;
    for (const auto& [raw, id] : raw_to_class_) out << YAML::Key << raw << YAML::Value << id;
    out << YAML::EndMap;
    out << YAML::Key << "unmapped_class" << YAML::Value << unmapped_class;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

void ClassTable::add(const ClassInfo& info) {
  if (!(info.search_radius >= 0.0) || !std::isfinite(info.search_radius))
    fail("class table", "class '" + info.name + "': search_radius must be >= 0");
  if (!(info.weight >= 0.0) || !std::isfinite(info.weight))
    fail("class table", "class '" + info.name + "': weight must be >= 0");
  classes_[info.id] = info;
}

const ClassInfo* ClassTable::find(ClassId id) const {
  auto it = classes_.find(id);
  return it == classes_.end() ? nullptr : &it->second;
}

const ClassInfo& ClassTable::at(ClassId id) const {
  const ClassInfo* c = find(id);
  if (!c) fail("class table", "unknown class " + std::to_string(id));
  return *c;
}

bool ClassTable::isProperty(ClassId id) const {
  const ClassInfo* c = find(id);
  return c && c->kind != PropertyKind::None;
}

std::vector<ClassId> ClassTable::ids() const {
  std::vector<ClassId> out;
  for (const auto& kv : classes_) out.push_back(kv.first);
  return out;
}

ClassId ClassTable::mapRaw(std::uint32_t raw) const {
  if (raw_to_class_.empty()) return static_cast<ClassId>(raw & 0xFFFFu);
  auto it = raw_to_class_.find(raw);
  return it == raw_to_class_.end() ? unmapped_class : it->second;
}

void ClassTable::mapRawLabel(std::uint32_t raw, ClassId id) { raw_to_class_[raw] = id; }

void ClassTable::checkCloud(const LabeledCloud& cloud, const std::string& where) const {
  // A flat look-up instead of a map search per point: this runs on every raw scan.
  std::vector<char> known(classes_.empty() ? 0 : std::size_t(classes_.rbegin()->first) + 1, 0);
  for (const auto& entry : classes_) known[entry.first] = 1;
  for (std::size_t i = 0; i < cloud.classes.size(); ++i)
    if (cloud.classes[i] >= known.size() || !known[cloud.classes[i]])
      fail(where, "point " + std::to_string(i) + " has class " + std::to_string(cloud.classes[i]) +
                      ", which is not in the class table");
}

}  // namespace hazmap
