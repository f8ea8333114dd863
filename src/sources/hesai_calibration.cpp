// Hesai angle-correction files: the CSV the sensor provides (and its web page exports), one
// header line ("Laser id,Elevation,Azimuth" or "Channel,Elevation,Azimuth") and one
// `id,elevation,azimuth` row per channel in degrees. Hesai's tools add nothing else to this
// format; a file that does not fit is refused with its line rather than guessed at.
#include "sources/hesai_calibration.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {

bool blank(const std::string& line) { return line.find_first_not_of(" \t\r") == std::string::npos; }

/// The three comma-separated numbers of a row; false if it is not exactly that.
bool parseRow(const std::string& line, double out[3]) {
  const char* p = line.c_str();
  for (int i = 0; i < 3; ++i) {
    char* end = nullptr;
    out[i] = std::strtod(p, &end);
    if (end == p || !std::isfinite(out[i])) return false;
    p = end;
    while (*p == ' ' || *p == '\t') ++p;
    if (i < 2 && *p++ != ',') return false;
  }
  while (*p == ' ' || *p == '\t' || *p == '\r') ++p;
  return *p == '\0';
}

}  // namespace

HesaiCalibration parseHesaiCalibration(const std::string& text, HesaiModel model, const std::string& where) {
  const int n = hesaiChannelCount(model);
  HesaiCalibration cal;
  cal.elevation_deg.assign(static_cast<std::size_t>(n), NAN);
  cal.azimuth_deg.assign(static_cast<std::size_t>(n), NAN);
  cal.source = where;
  std::istringstream in(text);
  std::string line;
  int line_no = 0, rows = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++line_no;
    if (blank(line)) continue;
    const std::string at = fmt::format("{}:{}", where, line_no);
    if (!header) {  // the header line names the columns; a file without it is not the sensor's
      if (line.find("Elevation") == std::string::npos || line.find("Azimuth") == std::string::npos)
        fail(at, "not a Hesai angle-correction file: the first line should name the columns (e.g. "
                 "\"Laser id,Elevation,Azimuth\")");
      header = true;
      continue;
    }
    double v[3];
    if (!parseRow(line, v))
      fail(at, "expected 'id,elevation,azimuth' (three numbers, degrees), got '" + line + "'");
    if (v[0] != std::floor(v[0]) || v[0] < 1 || v[0] > n)
      fail(at, fmt::format("channel id {} is not 1…{} ({} has {} channels)", v[0], n, hesaiModelName(model), n));
    const auto c = static_cast<std::size_t>(v[0]) - 1;
    if (!std::isnan(cal.elevation_deg[c])) fail(at, fmt::format("channel {} given twice", v[0]));
    if (std::abs(v[1]) > 90 || std::abs(v[2]) > 180)
      fail(at, fmt::format("angles out of range: elevation {}°, azimuth {}°", v[1], v[2]));
    cal.elevation_deg[c] = v[1];
    cal.azimuth_deg[c] = v[2];
    ++rows;
  }
  if (!header) fail(where, "empty angle-correction file");
  if (rows != n)
    fail(where, fmt::format("{} channels, {} has {}: not this model's angle-correction file", rows,
                            hesaiModelName(model), n));
  return cal;
}

HesaiCalibration loadHesaiCalibration(const std::filesystem::path& path, HesaiModel model) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path.string(), "cannot open the Hesai angle-correction file");
  std::ostringstream text;
  text << in.rdbuf();
  return parseHesaiCalibration(text.str(), model, path.string());
}

HesaiCalibration hesaiDefaultCalibration(HesaiModel model) {
  HesaiCalibration cal;
  cal.source = "built-in";
  for (const auto& a : hesai_detail::defaultAngles(model)) {
    cal.elevation_deg.push_back(a.elevation_deg);
    cal.azimuth_deg.push_back(a.azimuth_deg);
  }
  if (model == HesaiModel::PandarXT16)  // the manual: channel 1 at +15°, 2° apart
    for (int c = 0; c < 16; ++c) {
      cal.elevation_deg.push_back(15.0 - 2.0 * c);
      cal.azimuth_deg.push_back(0.0);
    }
  return cal;
}

}  // namespace hazmap
