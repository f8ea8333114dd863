// The non-template half of core/config_fields.hpp: scalar reading, ranges, messages, YAML text.
#include "hazmap/core/config_fields.hpp"

#include <array>
#include <charconv>

#include "hazmap/core/retired_keys.hpp"

namespace hazmap {

bool Range::contains(double v) const {
  if (!std::isfinite(v)) return false;
  if (lo && (lo_open ? !(v > *lo) : !(v >= *lo))) return false;
  if (hi && (hi_open ? !(v < *hi) : !(v <= *hi))) return false;
  return true;
}

std::string Range::text() const {
  using config_detail::formatNumber;
  if (lo && hi)
    return std::string(lo_open ? "(" : "[") + formatNumber(*lo) + ", " + formatNumber(*hi) + (hi_open ? ")" : "]");
  if (lo) return std::string(lo_open ? "> " : ">= ") + formatNumber(*lo);
  if (hi) return std::string(hi_open ? "< " : "<= ") + formatNumber(*hi);
  return "any number";
}

Range positive() { return {0.0, std::nullopt, true, false}; }
Range nonNegative() { return {0.0, std::nullopt, false, false}; }
Range atLeast(double lo) { return {lo, std::nullopt, false, false}; }
Range atMost(double hi) { return {std::nullopt, hi, false, false}; }
Range closed(double lo, double hi) { return {lo, hi, false, false}; }
Range openClosed(double lo, double hi) { return {lo, hi, true, false}; }
Range closedOpen(double lo, double hi) { return {lo, hi, false, true}; }
Range anyNumber() { return {}; }

void ConfigPlace::fail(const std::string& what) const {
  if (file.empty()) hazmap::fail(path.empty() ? "config" : path, what);
  hazmap::fail(file, path.empty() ? what : path + ": " + what);
}

namespace config_detail {

namespace {

std::string scalarText(const YAML::Node& node, const ConfigPlace& place, const char* expected) {
  if (!node || !node.IsScalar()) place.fail(std::string("must be ") + expected);
  return node.Scalar();
}

std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

}  // namespace

std::string formatNumber(double v) {
  if (std::isnan(v)) return ".nan";
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  std::array<char, 32> buf{};
  const auto r = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return std::string(buf.data(), r.ptr);
}

namespace {

// The scalar at `place` as a T, or a one-line error saying what it must be.
template <typename T>
T readScalar(const YAML::Node& node, const ConfigPlace& place, const char* expected, bool reject_minus = false) {
  const std::string text = scalarText(node, place, expected);
  const auto refuse = [&] { place.fail(std::string("must be ") + expected + ", got '" + text + "'"); };
  if (reject_minus && !text.empty() && text[0] == '-') refuse();
  try {
    return node.as<T>();
  } catch (const YAML::Exception&) {
    refuse();
  }
  return T{};  // not reached: refuse() throws
}

}  // namespace

double readNumber(const YAML::Node& node, const ConfigPlace& place) {
  return readScalar<double>(node, place, "a number");
}
long long readInteger(const YAML::Node& node, const ConfigPlace& place) {
  return readScalar<long long>(node, place, "a whole number");
}
std::uint64_t readUnsigned(const YAML::Node& node, const ConfigPlace& place) {
  return readScalar<std::uint64_t>(node, place, "a whole number >= 0", true);
}
bool readBool(const YAML::Node& node, const ConfigPlace& place) { return readScalar<bool>(node, place, "true or false"); }

// Valid UTF-8 without control characters: text that YAML and JSON write back unchanged.
bool plainText(const std::string& s) {
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    const int extra = c < 0x80 ? 0 : (c >> 5) == 0x6 ? 1 : (c >> 4) == 0xe ? 2 : (c >> 3) == 0x1e ? 3 : -1;
    if (extra < 0 || (extra == 0 && (c < 0x20 || c == 0x7f)) || i + extra >= s.size() + (extra ? 0 : 1)) return false;
    for (int k = 1; k <= extra; ++k)
      if ((static_cast<unsigned char>(s[i + k]) >> 6) != 0x2) return false;
    i += 1 + extra;
  }
  return true;
}

std::string readString(const YAML::Node& node, const ConfigPlace& place) {
  std::string text = scalarText(node, place, "a single value (text)");
  if (!plainText(text)) place.fail("must be printable UTF-8 text");
  return text;
}

void checkRange(double value, const Range& range, const ConfigPlace& place) {
  if (!range.contains(value))
    place.fail(std::string("must be ") + (range.lo && range.hi ? "in " : "") + range.text() + ", got " +
               formatNumber(value));
}

void unknownKey(const std::string& key, const std::vector<std::string>& valid, const ConfigPlace& place) {
  std::string best;
  std::size_t best_distance = std::max<std::size_t>(3, key.size() / 3) + 1;
  for (const auto& name : valid) {
    const std::size_t d = editDistance(key, name);
    if (d < best_distance) {
      best_distance = d;
      best = name;
    }
  }
  // A typo of a key the section has (one or two letters off) is a typo, even in a section whose
  // other keys moved elsewhere.
  const bool typo = !best.empty() && best_distance <= 2;
  if (const std::string note = retiredKeyNote(place.child(key).path); !note.empty() && !typo)
    place.fail("unknown key '" + key + "' (" + note + ")");
  place.fail("unknown key '" + key + "'" + (best.empty() ? "" : " (did you mean '" + best + "'?)"));
}

void requireMapping(const YAML::Node& node, const ConfigPlace& place) {
  if (!node.IsMap()) place.fail("must be a mapping of keys to values");
}

}  // namespace config_detail

YAML::Node parseConfigYaml(const std::string& text, const std::string& where) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    fail(where, "invalid YAML: " + e.msg + " at line " + std::to_string(e.mark.line + 1));
  }
}

namespace {

// Text that YAML would read back as a number, a bool or null is quoted.
bool looksLikeNonText(const std::string& s) {
  if (s.empty()) return true;
  try {
    const YAML::Node n = YAML::Load(s);
    if (!n.IsScalar()) return n.IsNull();
    double d;
    bool b;
    return YAML::convert<double>::decode(n, d) || YAML::convert<bool>::decode(n, b);
  } catch (const YAML::Exception&) {
    return false;  // the emitter quotes what it cannot write plainly
  }
}

void emitJson(YAML::Emitter& out, const nlohmann::json& j) {
  if (j.is_object()) {
    out << YAML::BeginMap;
    for (const auto& [k, v] : j.items()) {
      out << YAML::Key << k << YAML::Value;
      emitJson(out, v);
    }
    out << YAML::EndMap;
  } else if (j.is_array()) {
    out << YAML::Flow << YAML::BeginSeq;
    for (const auto& v : j) emitJson(out, v);
    out << YAML::EndSeq;
  } else if (j.is_number_float()) {
    out << config_detail::formatNumber(j.get<double>());
  } else if (j.is_number()) {
    out << j.dump();
  } else if (j.is_boolean()) {
    out << j.get<bool>();
  } else if (j.is_string()) {
    const std::string s = j.get<std::string>();
    out << (looksLikeNonText(s) ? YAML::DoubleQuoted : YAML::Auto) << s;
  } else {
    out << YAML::Null;
  }
}

}  // namespace

std::string jsonToYaml(const nlohmann::json& value) {
  YAML::Emitter out;
  emitJson(out, value);
  return std::string(out.c_str()) + "\n";
}

}  // namespace hazmap
