#pragma once
// The CLI's parameter flags, shared by run, odometry, register, loops and demo:
//   --mismatch-penalty A       α of the property ICP (paper eq. 2), for tracking and loops alike
//   --class-radius NAME=R      same-class search radius of a class (repeatable)
//   --set SECTION.KEY=VALUE    any setting of the command's config (repeatable; docs/configuration.md)
#include <CLI/CLI.hpp>
#include <memory>
#include <string>
#include <vector>

#include "hazmap/core/config_fields.hpp"
#include "hazmap/core/property_icp_config.hpp"

namespace hazmap::cli {

struct ParameterOptions {
  double mismatch_penalty = -1.0;
  std::vector<std::string> class_radius;
  std::vector<std::string> settings;

  /// The flags' α and radii over `base` (a config file's property_icp section, if any).
  PropertyIcpConfig propertyIcp(PropertyIcpConfig base = {}) const {
    if (mismatch_penalty >= 0.0) base.mismatch_penalty = mismatch_penalty;
    for (const auto& r : class_radius) addClassRadius(base, r);
    return base;
  }
  /// Applies every --set to `config` (keys relative to the command's config).
  template <typename Config>
  void applySettings(Config& config) const {
    for (const auto& s : settings) applyConfigSetting(config, s);
  }
};

/// Adds the flags; `set_help` says what --set keys are relative to (empty = no --set flag).
inline std::shared_ptr<ParameterOptions> addParameterOptions(CLI::App& app, const std::string& set_help) {
  auto o = std::make_shared<ParameterOptions>();
  app.add_option("--mismatch-penalty", o->mismatch_penalty,
                 "Property ICP: α (m²) added to the squared distance of a pair whose classes differ "
                 "(default: the class table's)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--class-radius", o->class_radius,
                 "Property ICP: same-class search radius of a class, NAME=METRES (repeatable, e.g. "
                 "--class-radius heat=3)")
      ->take_all()
      ->allow_extra_args(false);
  if (!set_help.empty())
    app.add_option("--set", o->settings, "Override one setting, KEY=VALUE (repeatable); " + set_help)
        ->allow_extra_args(false);
  return o;
}

}  // namespace hazmap::cli
