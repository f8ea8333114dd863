#include "hazmap/core/property_icp_config.hpp"

#include "hazmap/core/config_fields.hpp"

namespace hazmap {

const ConfigFields<PropertyIcpConfig>& configFields(ConfigTag<PropertyIcpConfig>) {
  using C = PropertyIcpConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("The paper's property-ICP parameters (eq. 2), applied to the class table that "
                      "tracking and loop verification share.")
          .number("mismatch_penalty", &C::mismatch_penalty, anyNumber(),
                  "α (m²) added to the squared distance of a pair whose classes differ (< 0 = the "
                  "class table's)")
          .numberMap("class_radius", &C::class_radius, nonNegative(),
                     "Same-class search radius (m) by class name, e.g. {heat: 3} (0 = "
                     "max_correspondence_distance; unlisted classes keep the class table's)");
  return fields;
}

void PropertyIcpConfig::validate() const { validateConfig(*this, "property_icp"); }

ClassTable PropertyIcpConfig::applyTo(ClassTable table, const std::string& where) const {
  validate();
  if (mismatch_penalty >= 0.0) table.mismatch_penalty = mismatch_penalty;
  for (const auto& [name, radius] : class_radius) {
    const ClassInfo* found = nullptr;
    std::string known;
    for (ClassId id : table.ids()) {
      const ClassInfo& info = table.at(id);
      if (info.name == name || std::to_string(id) == name) found = &info;
      known += (known.empty() ? "" : ", ") + info.name;
    }
    if (!found) fail(where, "class_radius: unknown class '" + name + "' (the class table has " + known + ")");
    ClassInfo changed = *found;
    changed.search_radius = radius;
    table.add(changed);
  }
  return table;
}

void addClassRadius(PropertyIcpConfig& config, const std::string& text, const std::string& flag) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size())
    fail(flag, "expected NAME=RADIUS (e.g. heat=3), got '" + text + "'");
  const YAML::Node value = parseConfigYaml(text.substr(eq + 1), flag);
  const std::string name = text.substr(0, eq);
  config.class_radius[name] = config_detail::readNumber(value, ConfigPlace{flag, name});
  validateConfig(config, "property_icp");
}

}  // namespace hazmap
