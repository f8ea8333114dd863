#pragma once
// The property-ICP parameters of the paper (eq. 2): the mismatch penalty α and the wider
// same-class search radii. They belong to the class table, which tracking and loop verification
// share, so they are set once (run YAML section `property_icp:`, CLI --mismatch-penalty and
// --class-radius NAME=R) and both stages use the same values.
#include <map>
#include <string>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/config_fwd.hpp"

namespace hazmap {

struct PropertyIcpConfig {
  /// α (m²), added to the squared distance of a pair whose classes differ; < 0 = the class
  /// table's mismatch_penalty.
  double mismatch_penalty = -1.0;
  /// Same-class search radius (m) by class name (or id); 0 = the ICP's
  /// max_correspondence_distance. Classes not listed keep the class table's radius.
  std::map<std::string, double> class_radius;

  bool empty() const { return mismatch_penalty < 0.0 && class_radius.empty(); }
  /// `table` with these settings applied. Throws hazmap::Error naming `where` and the class when
  /// a name is not in the table (the message lists the table's classes).
  ClassTable applyTo(ClassTable table, const std::string& where = "property_icp") const;
  void validate() const;
};

const ConfigFields<PropertyIcpConfig>& configFields(ConfigTag<PropertyIcpConfig>);

/// Parses a `--class-radius` value "NAME=RADIUS" into `config.class_radius`; errors name `flag`.
void addClassRadius(PropertyIcpConfig& config, const std::string& text,
                    const std::string& flag = "--class-radius");

}  // namespace hazmap
