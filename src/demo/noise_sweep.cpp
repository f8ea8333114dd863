#include "hazmap/demo/noise_sweep.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <cctype>
#include <ostream>
#include <set>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/demo/demo_simulator.hpp"
#include "hazmap/io/atomic_file.hpp"

namespace hazmap {

namespace {

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream in(text);
  while (std::getline(in, part, sep)) parts.push_back(part);
  if (!text.empty() && text.back() == sep) parts.emplace_back();
  return parts;
}

std::string lastPart(const std::string& key) {
  const auto dot = key.rfind('.');
  return dot == std::string::npos ? key : key.substr(dot + 1);
}

// A folder-safe name.
std::string slug(const std::string& text) {
  std::string s;
  for (char c : text) s += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-') ? c : '_';
  return s;
}

// The aggregate of a `demo --seeds` table2.json back into cells (for resuming).
std::map<std::string, std::map<std::string, SweepCell>> cellsFromJson(const nlohmann::json& j) {
  auto stats = [](const nlohmann::json& s) {
    return SeedStats{s.at("n").get<std::size_t>(), s.at("mean").get<double>(), s.at("sd").get<double>(),
                     s.at("min").get<double>(), s.at("max").get<double>()};
  };
  std::map<std::string, std::map<std::string, SweepCell>> cells;
  for (const auto& [setup, methods] : j.at("aggregate").items())
    for (const auto& [method, v] : methods.items())
      cells[setup][method] = {stats(v.at("map_error_m")), stats(v.at("ate_m"))};
  return cells;
}

std::map<std::string, std::map<std::string, SweepCell>> cellsOf(const SeedsReport& r) {
  std::map<std::string, std::map<std::string, SweepCell>> cells;
  for (const auto& a : r.aggregate) cells[toString(a.setup)][toString(a.method)] = {a.map_error_m, a.ate_m};
  return cells;
}

nlohmann::json pointJson(const SweepPoint& p, const NoiseSweepConfig& config) {
  return {{"id", p.id}, {"axis", p.axis}, {"label", p.label}, {"settings", p.settings},
          {"base", config.base}, {"scenario", config.demo.scenario}, {"frames", config.demo.frames},
          {"seeds", config.seeds}, {"frame_to_map", config.demo.frame_to_map}};
}

// A point's results: reloaded when its folder holds the same point's finished table2.json.
SweepPointResult runPoint(const SweepPoint& p, const NoiseSweepConfig& config, std::ostream& out) {
  const auto dir = config.demo.out_dir / p.id;
  const nlohmann::json spec = pointJson(p, config);
  std::error_code ec;
  if (std::filesystem::exists(dir / "point.json", ec) && std::filesystem::exists(dir / "table2.json", ec)) {
    try {
      if (nlohmann::json::parse(readTextFile(dir / "point.json")) == spec) {
        out << fmt::format("point {} ({}): reusing {}\n", p.id, p.label, (dir / "table2.json").string());
        return {p, cellsFromJson(nlohmann::json::parse(readTextFile(dir / "table2.json")))};
      }
    } catch (const nlohmann::json::exception&) {  // a broken leftover: run the point again
    }
  }
  DemoConfig demo = config.demo;
  demo.out_dir = dir;
  demo.simulator_settings = config.base;
  demo.simulator_settings.insert(demo.simulator_settings.end(), p.settings.begin(), p.settings.end());
  std::filesystem::create_directories(dir, ec);
  if (ec) fail(dir.string(), "cannot create sweep folder: " + ec.message());
  writeTextAtomically(dir / "point.json", spec.dump(2) + "\n");  // before table2.json, which marks it done
  out << fmt::format("\n##### point {} ({}{}{})\n", p.id, p.axis.empty() ? "" : p.axis + " = ", p.label,
                     p.settings.empty() ? "" : ": " + fmt::format("{}", fmt::join(p.settings, " ")))
      << std::flush;
  std::ostringstream log;  // the demo's own output goes to <point>/demo.log
  const SeedsReport seeds = runDemoSeeds(demo, config.seeds, log);
  writeTextAtomically(dir / "demo.log", log.str());
  return {p, cellsOf(seeds)};
}

nlohmann::json sweepJson(const NoiseSweepReport& report, const NoiseSweepConfig& config) {
  nlohmann::json points = nlohmann::json::array();
  for (const auto& r : report.points) {
    nlohmann::json cells = nlohmann::json::object();
    for (const auto& [setup, methods] : r.cells) {
      for (const auto& [method, c] : methods)
        cells[setup][method] = {{"map_error_mean_m", c.map_error_m.mean}, {"map_error_sd_m", c.map_error_m.sd},
                                {"n", c.map_error_m.n}, {"ate_mean_m", c.ate_m.mean}};
      cells[setup]["icp_over_property_icp"] = r.ratio(setup, false);
      cells[setup]["icp_pgo_over_property_icp_pgo"] = r.ratio(setup, true);
    }
    nlohmann::json p = pointJson(r.point, config);
    p["results"] = cells;
    points.push_back(p);
  }
  return {{"format", "hazmap-noise-sweep/1"}, {"scenario", config.demo.scenario}, {"seeds", config.seeds},
          {"frames", config.demo.frames}, {"base", config.base}, {"points", points}};
}

}  // namespace

std::string SweepAxis::name() const {
  std::string s;
  for (const auto& k : keys) s += (s.empty() ? "" : ":") + lastPart(k);
  return s;
}

SweepAxis parseSweepAxis(const std::string& text, const std::string& where) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size())
    fail(where, "expected KEY=V1,V2,... or KEY1:KEY2=A1:B1,A2:B2,..., got '" + text + "'");
  SweepAxis axis;
  axis.keys = split(text.substr(0, eq), ':');
  for (const auto& k : axis.keys)
    if (k.empty() || k.find('.') == std::string::npos)
      fail(where, "'" + k + "' in '" + text + "' is not a section.key simulator setting");
  for (const auto& step : split(text.substr(eq + 1), ',')) {
    auto values = split(step, ':');
    if (values.size() != axis.keys.size() || step.empty())
      fail(where, fmt::format("'{}' in '{}' has {} value(s) for {} key(s)", step, text, step.empty() ? 0 : values.size(),
                              axis.keys.size()));
    for (const auto& v : values)
      if (v.empty()) fail(where, "an empty value in '" + text + "'");
    axis.steps.push_back(std::move(values));
  }
  return axis;
}

SweepPoint parseSweepCombination(const std::string& text, const std::string& where) {
  const auto at = text.find('@');
  if (at == std::string::npos || at == 0 || at + 1 == text.size())
    fail(where, "expected NAME@section.key=value;section.key=value, got '" + text + "'");
  SweepPoint p;
  p.axis = "combinations";
  p.label = text.substr(0, at);
  p.settings = split(text.substr(at + 1), ';');
  for (const auto& s : p.settings)
    if (s.find('=') == std::string::npos || s.front() == '=')
      fail(where, "'" + s + "' in '" + text + "' is not section.key=value");
  return p;
}

double SweepPointResult::ratio(const std::string& setup, bool pgo) const {
  const auto s = cells.find(setup);
  if (s == cells.end()) return 0.0;
  const auto icp = s->second.find(pgo ? "icp+pgo" : "icp");
  const auto prop = s->second.find(pgo ? "property-icp+pgo" : "property-icp");
  if (icp == s->second.end() || prop == s->second.end() || prop->second.map_error_m.mean <= 0) return 0.0;
  return icp->second.map_error_m.mean / prop->second.map_error_m.mean;
}

std::vector<SweepPoint> sweepPoints(const NoiseSweepConfig& config) {
  std::vector<SweepPoint> points{{"p00-defaults", "", "defaults", {}}};
  for (const SweepAxis& axis : config.axes)
    for (const auto& step : axis.steps) {
      SweepPoint p{"", axis.name(), fmt::format("{}", fmt::join(step, "-")), {}};
      for (std::size_t k = 0; k < axis.keys.size(); ++k) p.settings.push_back(axis.keys[k] + "=" + step[k]);
      points.push_back(std::move(p));
    }
  for (const SweepPoint& c : config.combinations) points.push_back(c);
  for (std::size_t i = 1; i < points.size(); ++i)
    points[i].id = fmt::format("p{:02}-{}-{}", i, slug(points[i].axis), slug(points[i].label));
  // Every point must be a valid simulator config before anything runs.
  DemoConfig probe = config.demo;
  for (const SweepPoint& p : points) {
    probe.simulator_settings = config.base;
    probe.simulator_settings.insert(probe.simulator_settings.end(), p.settings.begin(), p.settings.end());
    demoSimulatorConfig(probe, "noise-sweep point '" + p.label + "'");
  }
  return points;
}

NoiseSweepReport runNoiseSweep(const NoiseSweepConfig& config, std::ostream& out) {
  const std::vector<SweepPoint> points = sweepPoints(config);
  // Points with the same simulator config (an axis step at the default) run once.
  std::map<std::string, std::size_t> done;
  NoiseSweepReport report;
  DemoConfig probe = config.demo;
  for (const SweepPoint& p : points) {
    probe.simulator_settings = config.base;
    probe.simulator_settings.insert(probe.simulator_settings.end(), p.settings.begin(), p.settings.end());
    const std::string key = demoSimulatorConfig(probe).toYamlString();
    if (const auto it = done.find(key); it != done.end()) {
      SweepPointResult same = report.points[it->second];
      out << fmt::format("point {} ({}): same simulator settings as {}\n", p.id, p.label, same.point.id);
      same.point = p;
      report.points.push_back(std::move(same));
      continue;
    }
    done[key] = report.points.size();
    report.points.push_back(runPoint(p, config, out));
    const SweepPointResult& r = report.points.back();
    out << fmt::format("  ICP / property ICP: paper's set-up {:.2f} (with PGO {:.2f}), frame to map {:.2f} ({:.2f})\n",
                       r.ratio("frame_to_frame", false), r.ratio("frame_to_frame", true),
                       r.ratio("frame_to_map", false), r.ratio("frame_to_map", true))
        << std::flush;
  }
  const auto& dir = config.demo.out_dir;
  writeTextAtomically(dir / "noise_sweep.json", sweepJson(report, config).dump(2) + "\n");
  const std::string md = noiseSweepMarkdown(report, config);
  writeTextAtomically(dir / "noise_sweep.md", md);
  writeNoiseSweepPng(dir / "noise_sweep.png", report, config);
  out << "\n" << md << fmt::format("\nWrote {0}/noise_sweep.json, .md, .png and one folder per point\n", dir.string());
  return report;
}

}  // namespace hazmap
