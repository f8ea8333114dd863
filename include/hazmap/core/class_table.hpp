#pragma once
// ClassTable: what each per-point class id means. A class has a name, the physical property it
// stands for, a display colour, and the paper's per-class correspondence-search settings
// (section IV-B: a labelled point searches a wider radius for points of its own class).
//
// A table may also map raw label ids found in files (e.g. SemanticKITTI's 80 = pole) to hazmap
// classes; raw ids without an entry map to `unmapped_class`.
#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap {

enum class PropertyKind { None, Heat, Water, Radiation, Other };

const char* toString(PropertyKind kind);
/// Parses "none", "heat", "water", "radiation", "other"; nullopt otherwise.
std::optional<PropertyKind> parsePropertyKind(const std::string& text);

using Rgb = std::array<std::uint8_t, 3>;

struct ClassInfo {
  ClassId id = 0;
  std::string name;
  PropertyKind kind = PropertyKind::None;
  Rgb color{160, 160, 160};
  /// Radius (m) within which a point of this class looks for a same-class partner. 0 = use the
  /// registration's default correspondence distance (the right choice for the "none" class).
  double search_radius = 0.0;
  /// Weight of this class's residuals in the ICP objective (beyond the paper; 1 = paper).
  double weight = 1.0;
  /// True when the labels mark the class's whole extent in every scan (label files, ground
  /// truth). False for labels from a camera: it sees part of a region, and the labelled patch
  /// ends where its view ends, which moves with the robot. Property ICP then trusts the class
  /// but not the patch's outline: a same-class pair gets the plane residual, not the 3-D one
  /// that would pull the two scans' differently cut patches onto each other, and the class
  /// searches only the registration's default correspondence radius, not its wider
  /// `search_radius` (the nearest same-class point metres away is another part of the region,
  /// not the point's counterpart). Loop closure builds its landmarks from the keyframe's
  /// neighbourhood on both sides (LoopClosureConfig::partial_landmark_window).
  bool whole_extent = true;
};

class ClassTable {
 public:
  /// hazmap's built-in table: 0 none, 1 heat, 2 water, 3 radiation.
  static ClassTable defaults();
  /// Table for SemanticKITTI labels: pole (80) → heat, traffic-sign (81) → radiation,
  /// trunk (71) → water, everything else → none. Rare, static, compact classes stand in for
  /// the paper's heat sources and puddles.
  static ClassTable semanticKitti();
  /// "default" / "semantic-kitti" name a built-in table; anything else is a YAML file path.
  static ClassTable load(const std::string& name_or_path);
  static ClassTable fromYamlFile(const std::filesystem::path& path);
  /// `where` names the source in error messages.
  static ClassTable fromYamlString(const std::string& yaml, const std::string& where);
  std::string toYamlString() const;

  /// Adds or replaces a class. Throws on a negative radius/weight.
  void add(const ClassInfo& info);
  bool contains(ClassId id) const { return classes_.count(id) != 0; }
  const ClassInfo* find(ClassId id) const;
  /// Throws hazmap::Error("class table: unknown class N") when absent.
  const ClassInfo& at(ClassId id) const;
  /// True for classes that carry a physical property (kind != None).
  bool isProperty(ClassId id) const;
  std::vector<ClassId> ids() const;
  std::size_t size() const { return classes_.size(); }

  /// Raw file label → class id (low 16 bits of a SemanticKITTI label are the raw id).
  ClassId mapRaw(std::uint32_t raw) const;
  bool hasRawMapping() const { return !raw_to_class_.empty(); }
  void mapRawLabel(std::uint32_t raw, ClassId id);
  const std::map<std::uint32_t, ClassId>& rawMapping() const { return raw_to_class_; }
  ClassId unmapped_class = 0;

  /// Throws hazmap::Error naming `where` if any point's class is not in the table.
  void checkCloud(const LabeledCloud& cloud, const std::string& where) const;

  /// The paper's α (eq. 2): penalty added to the squared distance when classes differ (m²).
  double mismatch_penalty = 1.0;

 private:
  std::map<ClassId, ClassInfo> classes_;
  std::map<std::uint32_t, ClassId> raw_to_class_;
};

}  // namespace hazmap
