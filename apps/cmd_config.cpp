// hazmap config: every setting's key, default, range and meaning, from the field tables
// (core/config_fields.hpp). `--markdown` writes docs/configuration.md (a test keeps it current).
#include <iostream>
#include <memory>
#include <sstream>

#include "command.hpp"
#include "hazmap/core/config_fields.hpp"
#include "hazmap/core/retired_keys.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "hazmap/registration/global_registration.hpp"
#include "hazmap/sim/simulator.hpp"

namespace hazmap::cli {
namespace {

struct ConfigOptions {
  std::string target = "run";
  std::string method = "property-icp+pgo";
  std::string check;
  bool dump_defaults = false;
  bool json = false;
  bool markdown = false;
};

std::string cell(std::string text) {
  std::string out;
  for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

std::string scalarText(const nlohmann::json& value) {
  std::string yaml = jsonToYaml(value);
  while (!yaml.empty() && yaml.back() == '\n') yaml.pop_back();
  return yaml;
}

// One table per section, nested sections after their parent's table.
void markdownSection(std::ostream& out, const std::string& path, const std::string& doc,
                     const std::vector<FieldInfo>& fields) {
  out << "\n### `" << path << "`\n\n" << doc << "\n\n";
  bool any_scalar = false;
  for (const auto& f : fields) any_scalar |= f.type != "section";
  if (any_scalar) {
    out << "| key | type | default | allowed | meaning |\n|---|---|---|---|---|\n";
    for (const auto& f : fields)
      if (f.type != "section")
        out << "| `" << f.name << "` | " << f.type << " | `" << cell(scalarText(f.default_value)) << "` | "
            << cell(f.allowed) << " | " << cell(f.doc) << " |\n";
  }
  for (const auto& f : fields)
    if (f.type == "section") markdownSection(out, path.empty() ? f.name : path + "." + f.name, f.doc, f.children);
    else if (!f.children.empty())  // a list of sub-configs: the fields of one item
      markdownSection(out, path + "." + f.name + "[]", "One item of `" + f.name + "`.", f.children);
}

std::string markdown() {
  std::ostringstream out;
  out << "# Configuration\n\n"
         "Every setting hazmap reads from YAML, with its default, allowed values and meaning.\n"
         "This page is generated from the field tables in the code (`hazmap config --markdown >\n"
         "docs/configuration.md`; a test fails when it is out of date). Defaults are the config\n"
         "structs' own initialisers. Errors name the file and the key\n"
         "(`run.yaml: odometry.registration.max_iterations: must be >= 1, got 0`), and unknown keys\n"
         "are errors that suggest the closest valid key. An experiment that was measured and not\n"
         "adopted is not a key: its write-up is in docs/history/, and a retired key's error names it.\n\n"
         "- `hazmap run --config FILE` and `hazmap demo` read the run sections below; any key can\n"
         "  also be set with `--set section.key=value` (YAML syntax for the value, repeatable).\n"
         "- `hazmap odometry --config` reads the `odometry` section, `hazmap loops --config` the\n"
         "  `loop_closure` section, `hazmap register --config` the keys of\n"
         "  `odometry.registration`, `hazmap graph optimize --config` the `graph` section (each at\n"
         "  the file's top level or under its section name); `--set` keys are relative to it.\n"
         "- The property-ICP parameters (α, class search radii) are set once, in `property_icp`\n"
         "  or with `--mismatch-penalty A` and `--class-radius NAME=R` (run, odometry, register,\n"
         "  loops, demo), and tracking and loop verification use the same values.\n"
         "- `hazmap config --dump-defaults [--json] [--for run|simulate]` prints the defaults;\n"
         "  `hazmap config --check FILE` validates a file. `run.json` stores a run's parameters in\n"
         "  this layout.\n"
         "- One ICP is configured, tracking's (`odometry.registration`): loop verification\n"
         "  (`loop_closure.verification.registration`) and the global registration's refinement\n"
         "  (`odometry.global_registration.refinement`) state only what they change from it.\n"
         "\nDefaults of the run are those of `--method property-icp+pgo`; the other methods switch\n"
         "`odometry.registration.use_classes` (which loop verification follows) and\n"
         "`loop_closure.method` (distance for the conventional baselines).\n"
         "\n## Run (`hazmap run`, `hazmap demo`)\n";
  const SlamConfig run = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  for (const auto& f : describeConfig(run)) markdownSection(out, f.name, f.doc, f.children);
  out << "\n## Keys that moved or became constants\n\n" << config_detail::movedAndConstantKeysMarkdown();
  out << "\n## Global registration (`hazmap register --global --config`)\n";
  markdownSection(out, "global_registration", fieldsOf<GlobalRegistrationConfig>().doc(),
                  describeConfig<GlobalRegistrationConfig>());
  out << "\n## Simulator (`hazmap simulate --config`)\n";
  markdownSection(out, "simulate", fieldsOf<sim::SimulatorConfig>().doc(), describeConfig<sim::SimulatorConfig>());
  return out.str();
}

void run(const ConfigOptions& o) {
  if (o.target != "run" && o.target != "simulate") fail("--for", "expected run or simulate, got '" + o.target + "'");
  if (o.markdown) {
    std::cout << markdown();
    return;
  }
  if (!o.check.empty()) {
    if (o.target == "run") SlamConfig::forMethod(parseSlamMethod(o.method)).applyYamlFile(o.check);
    else sim::SimulatorConfig::fromYamlFile(o.check).validate(o.check);
    std::cout << o.check << ": ok\n";
    return;
  }
  const nlohmann::json defaults = o.target == "run" ? configToJson(SlamConfig::forMethod(parseSlamMethod(o.method)))
                                                    : configToJson(sim::SimulatorConfig{});
  std::cout << (o.json ? defaults.dump(2) + "\n" : jsonToYaml(defaults));
}

const RegisterCommand registration{{
    "config",
    "Print the default settings (YAML or JSON), the configuration reference (Markdown), or "
    "check a config file",
    [](CLI::App& app) {
      auto o = std::make_shared<ConfigOptions>();
      app.add_flag("--dump-defaults", o->dump_defaults, "Print every setting with its default (the default action)");
      app.add_flag("--json", o->json, "JSON instead of YAML");
      app.add_flag("--markdown", o->markdown, "The configuration reference (docs/configuration.md)");
      app.add_option("--for", o->target, "run (hazmap run/demo) | simulate (hazmap simulate)");
      app.add_option("--method", o->method, "Run defaults of this method (they differ in use_classes and loop search)");
      app.add_option("--check", o->check, "Validate FILE (unknown keys, ranges) and print ok");
      app.callback([o] { run(*o); });
    }}};

}  // namespace
}  // namespace hazmap::cli
