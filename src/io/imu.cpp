// imu.txt and IMU streams (include/hazmap/io/imu.hpp).
#include "hazmap/io/imu.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "io/io_detail.hpp"

namespace hazmap {

namespace {

ImuSample parseImuLine(const std::vector<std::string_view>& tok, const std::filesystem::path& path, std::size_t line) {
  if (tok.size() != 7)
    io_detail::failAtLine(path, line, "expected 7 numbers (time wx wy wz ax ay az), found " + std::to_string(tok.size()));
  double v[7];
  for (int k = 0; k < 7; ++k) {
    v[k] = io_detail::numberAt(tok[k], path, line);
    if (!std::isfinite(v[k])) io_detail::failAtLine(path, line, "non-finite value");
  }
  return {v[0], Eigen::Vector3d(v[1], v[2], v[3]), Eigen::Vector3d(v[4], v[5], v[6])};
}

}  // namespace

ImuStreamReport cleanImuStream(std::vector<ImuSample>& samples, double max_gap) {
  ImuStreamReport report;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (kept > 0 && !(samples[i].time > samples[kept - 1].time)) {
      ++report.out_of_order;
      continue;
    }
    if (kept > 0) {
      const double dt = samples[i].time - samples[kept - 1].time;
      if (dt > max_gap) ++report.gaps;
      report.longest_gap = std::max(report.longest_gap, dt);
    }
    samples[kept++] = samples[i];
  }
  samples.resize(kept);
  if (report.gaps == 0) report.longest_gap = 0.0;
  return report;
}

std::string describe(const ImuStreamReport& report, const std::string& where) {
  std::string out;
  if (report.out_of_order > 0)
    out += std::to_string(report.out_of_order) + " IMU samples out of time order dropped";
  if (report.gaps > 0) {
    if (!out.empty()) out += "; ";
    out += std::to_string(report.gaps) + " gaps in the IMU stream (longest " + std::to_string(report.longest_gap) +
           " s) bridged with constant velocity";
  }
  return out.empty() ? out : where + ": " + out;
}

std::vector<ImuSample> readImuFile(const std::filesystem::path& path) {
  const io_detail::FileBytes bytes = io_detail::readFileBytes(path);
  io_detail::LineReader lines(bytes.view());
  std::string_view line;
  std::vector<std::string_view> tok;
  std::vector<ImuSample> out;
  while (lines.next(line)) {
    const auto t = io_detail::trim(line);
    if (t.empty() || t.front() == '#') continue;
    io_detail::splitTokens(t, tok);
    out.push_back(parseImuLine(tok, path, lines.lineNumber()));
  }
  return out;
}

void writeImuFile(const std::filesystem::path& path, const std::vector<ImuSample>& samples) {
  std::string text = "# time wx wy wz ax ay az: s, rad/s, m/s² (specific force), sensor frame\n";
  for (const auto& s : samples) {
    io_detail::appendNumber(text, s.time);
    for (int k = 0; k < 3; ++k) text += ' ', io_detail::appendNumber(text, s.gyro[k]);
    for (int k = 0; k < 3; ++k) text += ' ', io_detail::appendNumber(text, s.accel[k]);
    text += '\n';
  }
  writeTextAtomically(path, text);
}

std::vector<ImuSample> imuSpan(const std::vector<ImuSample>& samples, double t0, double t1) {
  const auto before = [](const ImuSample& s, double t) { return s.time < t; };
  const auto after = [](double t, const ImuSample& s) { return t < s.time; };
  auto first = std::lower_bound(samples.begin(), samples.end(), t0, before);
  auto last = std::upper_bound(first, samples.end(), t1, after);
  // One sample beyond an end that falls between two samples, none when one sits on it.
  if (first != samples.begin() && (first == samples.end() || first->time > t0)) --first;
  if (last != samples.end() && (last == samples.begin() || std::prev(last)->time < t1)) ++last;
  if (first == last || first->time > t0 || std::prev(last)->time < t1) return {};
  for (auto it = first; std::next(it) != last; ++it)
    if (std::next(it)->time - it->time > kImuMaxGap) return {};
  return {first, last};
}

}  // namespace hazmap
