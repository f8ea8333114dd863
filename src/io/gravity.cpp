// gravity.txt: the IMU's gravity direction per scan (include/hazmap/io/gravity.hpp).
#include "hazmap/io/gravity.hpp"

#include <charconv>
#include <cmath>
#include <string>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "io/io_detail.hpp"

namespace hazmap {

namespace {

GravitySample parseGravityLine(const std::vector<std::string_view>& tok, const std::filesystem::path& path,
                               std::size_t line) {
  if (tok.size() != 5)
    io_detail::failAtLine(path, line, "expected 5 numbers (time dx dy dz sigma_deg), found " + std::to_string(tok.size()));
  double v[5];
  for (int k = 0; k < 5; ++k) {
    v[k] = io_detail::numberAt(tok[k], path, line);
    if (!std::isfinite(v[k])) io_detail::failAtLine(path, line, "non-finite value");
  }
  GravitySample s;
  s.time = v[0];
  s.down = Eigen::Vector3d(v[1], v[2], v[3]);
  if (std::abs(s.down.norm() - 1.0) > 1e-3)
    io_detail::failAtLine(path, line, "gravity direction is not a unit vector (length " + std::to_string(s.down.norm()) + ")");
  s.down.normalize();
  if (!(v[4] > 0.0)) io_detail::failAtLine(path, line, "sigma_deg must be > 0");
  s.sigma_deg = v[4];
  return s;
}

void appendNumber(std::string& out, double v) {
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, res.ptr);
}

}  // namespace

std::vector<GravitySample> readGravityFile(const std::filesystem::path& path, std::optional<std::size_t> scans) {
  const io_detail::FileBytes bytes = io_detail::readFileBytes(path);
  io_detail::LineReader lines(bytes.view());
  std::string_view line;
  std::vector<std::string_view> tok;
  std::vector<GravitySample> out;
  while (lines.next(line)) {
    const auto t = io_detail::trim(line);
    if (t.empty() || t.front() == '#') continue;
    io_detail::splitTokens(t, tok);
    out.push_back(parseGravityLine(tok, path, lines.lineNumber()));
  }
  if (scans && out.size() != *scans)
    fail(path.string(), "has " + std::to_string(out.size()) + " gravity lines but the sequence has " +
                            std::to_string(*scans) + " scans (one line per scan expected)");
  return out;
}

void writeGravityFile(const std::filesystem::path& path, const std::vector<GravitySample>& samples) {
  std::string text = "# time dx dy dz sigma_deg: gravity (down, unit vector) in the sensor frame per scan\n";
  for (const auto& s : samples) {
    appendNumber(text, s.time);
    for (int k = 0; k < 3; ++k) text += ' ', appendNumber(text, s.down[k]);
    text += ' ';
    appendNumber(text, s.sigma_deg);
    text += '\n';
  }
  writeTextAtomically(path, text);
}

}  // namespace hazmap
