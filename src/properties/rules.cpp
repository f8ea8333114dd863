#include "hazmap/properties/rules.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"

namespace hazmap {

struct RuleExpression::Node {
  enum class Kind { Compare, And, Or, Not } kind = Kind::Compare;
  enum class Op { Ge, Le, Gt, Lt, Eq, Ne } op = Op::Ge;
  int slot = 0;
  float constant = 0;
  std::shared_ptr<const Node> left, right;

  bool evaluate(const float* v) const {
    switch (kind) {
      case Kind::And: return left->evaluate(v) && right->evaluate(v);
      case Kind::Or: return left->evaluate(v) || right->evaluate(v);
      case Kind::Not: return !left->evaluate(v);
      case Kind::Compare: break;
    }
    const float x = v[slot];
    if (std::isnan(x)) return false;  // not observed: no comparison holds
    switch (op) {
      case Op::Ge: return x >= constant;
      case Op::Le: return x <= constant;
      case Op::Gt: return x > constant;
      case Op::Lt: return x < constant;
      case Op::Eq: return x == constant;
      case Op::Ne: return x != constant;
    }
    return false;
  }
};

namespace {

using Node = RuleExpression::Node;
using NodePtr = std::shared_ptr<const Node>;

/// Recursive-descent parser: or := and ('or' and)*; and := unary ('and' unary)*;
/// unary := 'not' unary | '(' or ')' | name op number.
class Parser {
 public:
  Parser(const std::string& text, const std::string& where, std::vector<std::string>& vars)
      : s_(text), where_(where), vars_(vars) {}

  NodePtr parseAll() {
    NodePtr n = parseOr();
    skipSpace();
    if (pos_ != s_.size()) error("unexpected '" + s_.substr(pos_) + "'");
    return n;
  }

 private:
  [[noreturn]] void error(const std::string& what) {
    fail(where_, "rule '" + s_ + "': " + what + " at column " + std::to_string(pos_ + 1));
  }
  void skipSpace() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
  }
  std::string word() {
    skipSpace();
    const std::size_t start = pos_;
    while (pos_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[pos_])) || s_[pos_] == '_')) ++pos_;
    return s_.substr(start, pos_ - start);
  }
  bool keyword(const char* k) {
    const std::size_t save = pos_;
    if (word() == k) return true;
    pos_ = save;
    return false;
  }
  static NodePtr join(Node::Kind kind, NodePtr l, NodePtr r) {
    auto n = std::make_shared<Node>();
    n->kind = kind;
    n->left = std::move(l);
    n->right = std::move(r);
    return n;
  }
  NodePtr parseOr() {
    NodePtr n = parseAnd();
    while (keyword("or")) n = join(Node::Kind::Or, n, parseAnd());
    return n;
  }
  NodePtr parseAnd() {
    NodePtr n = parseUnary();
    while (keyword("and")) n = join(Node::Kind::And, n, parseUnary());
    return n;
  }
  NodePtr parseUnary() {
    if (keyword("not")) return join(Node::Kind::Not, parseUnary(), nullptr);
    skipSpace();
    if (pos_ < s_.size() && s_[pos_] == '(') {
      ++pos_;
      NodePtr n = parseOr();
      skipSpace();
      if (pos_ >= s_.size() || s_[pos_] != ')') error("missing ')'");
      ++pos_;
      return n;
    }
    return parseComparison();
  }
  NodePtr parseComparison() {
    const std::string name = word();
    if (name.empty() || std::isdigit(static_cast<unsigned char>(name[0]))) error("expected a channel name");
    if (name == "and" || name == "or" || name == "not") error("expected a channel name, found '" + name + "'");
    auto n = std::make_shared<Node>();
    skipSpace();
    static const std::pair<const char*, Node::Op> ops[] = {{">=", Node::Op::Ge}, {"<=", Node::Op::Le},
                                                          {"==", Node::Op::Eq}, {"!=", Node::Op::Ne},
                                                          {">", Node::Op::Gt},  {"<", Node::Op::Lt}};
    bool found = false;
    for (const auto& [text, op] : ops)
      if (s_.compare(pos_, std::char_traits<char>::length(text), text) == 0) {
        n->op = op;
        pos_ += std::char_traits<char>::length(text);
        found = true;
        break;
      }
    if (!found) error("expected a comparison (>= <= > < == !=) after '" + name + "'");
    skipSpace();
    double value = 0;
    const auto res = std::from_chars(s_.data() + pos_, s_.data() + s_.size(), value);
    if (res.ec != std::errc() || !std::isfinite(value)) error("expected a number");
    pos_ = static_cast<std::size_t>(res.ptr - s_.data());
    n->constant = static_cast<float>(value);
    const auto it = std::find(vars_.begin(), vars_.end(), name);
    n->slot = static_cast<int>(it - vars_.begin());
    if (it == vars_.end()) vars_.push_back(name);
    return n;
  }

  const std::string& s_;
  const std::string& where_;
  std::vector<std::string>& vars_;
  std::size_t pos_ = 0;
};

}  // namespace

RuleExpression RuleExpression::parse(const std::string& text, const std::string& where) {
  RuleExpression e;
  e.text_ = text;
  e.root_ = Parser(text, where, e.variables_).parseAll();
  return e;
}

bool RuleExpression::evaluate(const float* values) const { return root_->evaluate(values); }

void PropertyRules::add(ClassRule rule) {
  if (rule.expression.variables().size() > 16)
    fail(rule.expression.text(), "a rule may use at most 16 variables");
  std::vector<int> slots;
  for (const std::string& v : rule.expression.variables()) {
    const auto it = std::find(variables_.begin(), variables_.end(), v);
    slots.push_back(static_cast<int>(it - variables_.begin()));
    if (it == variables_.end()) variables_.push_back(v);
  }
  slots_.push_back(std::move(slots));
  rules_.push_back(std::move(rule));
}

namespace {

ClassId classByName(const ClassTable& table, const std::string& name, const std::string& where) {
  for (ClassId id : table.ids())
    if (table.at(id).name == name) return id;
  fail(where, "rule class '" + name + "' is not in the class table");
}

}  // namespace

PropertyRules PropertyRules::parse(const std::string& yaml, const std::string& where, const ClassTable& table) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    fail(where, std::string("not valid YAML: ") + e.what());
  }
  if (root.IsMap() && root["rules"]) root = root["rules"];
  std::vector<std::pair<std::string, YAML::Node>> entries;
  if (root.IsMap()) {
    for (const auto& kv : root) entries.emplace_back(kv.first.as<std::string>(), kv.second);
  } else if (root.IsSequence()) {
    for (const auto& item : root) {
      if (!item.IsMap() || item.size() != 1) fail(where, "each rule must be one 'class: expression' pair");
      for (const auto& kv : item) entries.emplace_back(kv.first.as<std::string>(), kv.second);
    }
  } else {
    fail(where, "expected rules as 'class: expression' lines (or a list under 'rules:')");
  }
  if (entries.empty()) fail(where, "no rules");
  PropertyRules rules;
  for (const auto& [name, node] : entries) {
    if (!node.IsScalar()) fail(where, "rule '" + name + "' must be an expression string");
    rules.add({classByName(table, name, where), name,
               RuleExpression::parse(node.as<std::string>(), where + ": " + name)});
  }
  return rules;
}

PropertyRules PropertyRules::fromYamlFile(const std::filesystem::path& path, const ClassTable& table) {
  return parse(readTextFile(path), path.string(), table);
}

PropertyRules PropertyRules::defaults(const std::vector<std::string>& channels, const ClassTable& table) {
  static const std::tuple<PropertyKind, const char*, const char*> builtin[] = {
      {PropertyKind::Heat, "temperature", "temperature >= 60"},
      {PropertyKind::Water, "nir_reflectance", "nir_reflectance <= 0.2 and normal_z > 0.9"},
      {PropertyKind::Radiation, "dose_rate", "dose_rate >= 10"}};
  PropertyRules rules;
  for (const auto& [kind, channel, text] : builtin) {
    if (std::find(channels.begin(), channels.end(), channel) == channels.end()) continue;
    for (ClassId id : table.ids())
      if (table.at(id).kind == kind) {
        rules.add({id, table.at(id).name, RuleExpression::parse(text, "built-in rules")});
        break;
      }
  }
  return rules;
}

bool PropertyRules::usesNormalZ() const {
  return std::find(variables_.begin(), variables_.end(), "normal_z") != variables_.end();
}

ClassId PropertyRules::classify(const float* values) const {
  float local[16];
  for (std::size_t r = 0; r < rules_.size(); ++r) {
    const auto& slots = slots_[r];
    const std::size_t k = std::min<std::size_t>(slots.size(), 16);
    for (std::size_t j = 0; j < k; ++j) local[j] = values[slots[j]];
    if (rules_[r].expression.evaluate(local)) return rules_[r].class_id;
  }
  return 0;
}

void PropertyRules::checkChannels(const std::vector<std::string>& channels, const std::string& where) const {
  for (const std::string& v : variables_)
    if (v != "normal_z" && std::find(channels.begin(), channels.end(), v) == channels.end())
      fail(where, "rules use '" + v + "' but no camera measures it (cameras give: " +
                      [&] {
                        std::string s;
                        for (const auto& c : channels) s += (s.empty() ? "" : ", ") + c;
                        return s.empty() ? std::string("none") : s;
                      }() + ")");
}

}  // namespace hazmap
