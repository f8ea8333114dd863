#pragma once
// Class rules: which property class a point gets from its channel values. YAML, first match wins,
// points no rule matches get class 0 (none):
//   heat: temperature >= 60
//   water: nir_reflectance <= 0.2 and normal_z > 0.9
//   radiation: dose_rate >= 10
// (or the same as a list under `rules:`, `- heat: temperature >= 60`). An expression compares
// variables with numbers (>= <= > < == !=) joined by `and`, `or`, `not` and parentheses; the
// variables are channel names and `normal_z` (|z| of the unit surface normal in the world
// frame: 1 on floors). A comparison with a value that was not observed (NaN) is false, so an
// unobserved point is never a hazard by accident.
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"

namespace hazmap {

/// A compiled boolean expression over named variables.
class RuleExpression {
 public:
  /// Throws hazmap::Error("<where>: ...") naming the position of a syntax error.
  static RuleExpression parse(const std::string& text, const std::string& where);
  /// Variable names in slot order (values passed to evaluate() follow it).
  const std::vector<std::string>& variables() const { return variables_; }
  bool evaluate(const float* values) const;
  const std::string& text() const { return text_; }

  struct Node;
 private:
  std::string text_;
  std::vector<std::string> variables_;
  std::shared_ptr<const Node> root_;
};

struct ClassRule {
  ClassId class_id = 0;
  std::string class_name;
  RuleExpression expression;
};

class PropertyRules {
 public:
  /// Class names resolve through `table`; `where` names the text in errors.
  static PropertyRules parse(const std::string& yaml, const std::string& where, const ClassTable& table);
  static PropertyRules fromYamlFile(const std::filesystem::path& path, const ClassTable& table);
  /// The built-in rules for the channels at hand: heat `temperature >= 60`, water
  /// `nir_reflectance <= 0.2 and normal_z > 0.9`, radiation `dose_rate >= 10`, each only when
  /// its channel is present and its class is in the table.
  static PropertyRules defaults(const std::vector<std::string>& channels, const ClassTable& table);

  const std::vector<ClassRule>& rules() const { return rules_; }
  /// All variables of all rules, in slot order; classify() takes values in this order.
  const std::vector<std::string>& variables() const { return variables_; }
  bool usesNormalZ() const;
  /// The first matching rule's class, else 0.
  ClassId classify(const float* values) const;
  /// Checks every variable is `normal_z` or one of `channels`; throws naming `where`.
  void checkChannels(const std::vector<std::string>& channels, const std::string& where) const;

 private:
  void add(ClassRule rule);
  std::vector<ClassRule> rules_;
  std::vector<std::string> variables_;
  std::vector<std::vector<int>> slots_;  ///< per rule: its variables' slots in variables_
};

}  // namespace hazmap
