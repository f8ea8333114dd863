#include "hazmap/io/trajectory.hpp"

#include <cmath>
#include <string>
#include <type_traits>
#include <vector>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "io/io_detail.hpp"

namespace hazmap {

namespace {

/// Calls `row(line_number, tokens)` for every line that is neither blank nor a '#' comment, until
/// a `row` that returns bool returns false.
template <typename Row>
void forEachRow(const std::filesystem::path& path, Row&& row) {
  const io_detail::FileBytes bytes = io_detail::readFileBytes(path);
  io_detail::LineReader lines(bytes.view());
  std::string_view line;
  std::vector<std::string_view> tok;
  while (lines.next(line)) {
    const auto t = io_detail::trim(line);
    if (t.empty() || t.front() == '#') continue;
    io_detail::splitTokens(t, tok);
    if constexpr (std::is_same_v<decltype(row(lines.lineNumber(), tok)), bool>) {
      if (!row(lines.lineNumber(), tok)) return;
    } else {
      row(lines.lineNumber(), tok);
    }
  }
}

/// Largest deviation of RᵀR from identity, and det(R).
bool isRotation(const Eigen::Matrix3d& R) {
  return ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-3) &&
         std::abs(R.determinant() - 1.0) < 1e-3;
}

}  // namespace

Trajectory readKittiTrajectory(const std::filesystem::path& path) {
  Trajectory out;
  forEachRow(path, [&](std::size_t ln, const std::vector<std::string_view>& tok) {
    if (tok.size() != 12)
      io_detail::failAtLine(path, ln, "expected 12 numbers (KITTI row-major 3x4 pose), found " +
                                          std::to_string(tok.size()));
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) {
        const double v = io_detail::numberAt(tok[r * 4 + c], path, ln);
        if (!std::isfinite(v)) io_detail::failAtLine(path, ln, "non-finite value in pose");
        T.matrix()(r, c) = v;
      }
    if (!isRotation(T.linear())) io_detail::failAtLine(path, ln, "the 3x3 part is not a rotation matrix");
    out.push_back(static_cast<double>(out.size()), T);
  });
  return out;
}

Trajectory readTumTrajectory(const std::filesystem::path& path) {
  Trajectory out;
  forEachRow(path, [&](std::size_t ln, const std::vector<std::string_view>& tok) {
    if (tok.size() != 8)
      io_detail::failAtLine(path, ln, "expected 8 numbers (TUM: t tx ty tz qx qy qz qw), found " +
                                          std::to_string(tok.size()));
    double v[8];
    for (int k = 0; k < 8; ++k) {
      v[k] = io_detail::numberAt(tok[k], path, ln);
      if (!std::isfinite(v[k])) io_detail::failAtLine(path, ln, "non-finite value");
    }
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);  // Eigen's constructor is (w, x, y, z)
    const double norm = q.norm();
    if (norm < 1e-6) io_detail::failAtLine(path, ln, "quaternion has zero length");
    if (std::abs(norm - 1.0) > 1e-2)
      io_detail::failAtLine(path, ln, "quaternion is not normalised (length " + std::to_string(norm) + ")");
    q.normalize();
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = q.toRotationMatrix();
    T.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
    out.push_back(v[0], T);
  });
  return out;
}

Trajectory readTrajectory(const std::filesystem::path& path, TrajectoryFormat format) {
  return format == TrajectoryFormat::Kitti ? readKittiTrajectory(path) : readTumTrajectory(path);
}

namespace {

struct FirstDataLine {
  std::size_t columns = 0, line = 0;  // columns 0: no data line
};

FirstDataLine firstDataLine(const std::filesystem::path& path) {
  FirstDataLine first;
  forEachRow(path, [&](std::size_t line, const std::vector<std::string_view>& tok) {
    first = {tok.size(), line};
    return false;
  });
  return first;
}

}  // namespace

std::optional<TrajectoryFormat> detectTrajectoryFormat(const std::filesystem::path& path) {
  const std::size_t columns = firstDataLine(path).columns;
  if (columns == 12) return TrajectoryFormat::Kitti;
  if (columns == 8) return TrajectoryFormat::Tum;
  return std::nullopt;
}

Trajectory readTrajectoryAuto(const std::filesystem::path& path) {
  const auto [columns, line] = firstDataLine(path);
  if (columns == 0) return {};
  if (columns == 12) return readKittiTrajectory(path);
  if (columns == 8) return readTumTrajectory(path);
  io_detail::failAtLine(path, line, "expected 12 numbers (KITTI) or 8 (TUM), found " + std::to_string(columns));
}

void writeKittiTrajectory(const std::filesystem::path& path, const Trajectory& trajectory) {
  std::string out;
  out.reserve(trajectory.size() * 200);
  for (const auto& T : trajectory.poses) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) {
        if (r || c) out += ' ';
        io_detail::appendNumber(out, T.matrix()(r, c));
      }
    out += '\n';
  }
  writeTextAtomically(path, out);
}

void writeTumTrajectory(const std::filesystem::path& path, const Trajectory& trajectory) {
  if (trajectory.stamps.size() != trajectory.poses.size())
    fail(path.string(), "trajectory has " + std::to_string(trajectory.stamps.size()) + " stamps but " +
                            std::to_string(trajectory.poses.size()) + " poses");
  std::string out = "# timestamp tx ty tz qx qy qz qw\n";
  out.reserve(trajectory.size() * 160);
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const auto& T = trajectory.poses[i];
    const Eigen::Quaterniond q(T.linear());
    const double v[8] = {trajectory.stamps[i], T.translation().x(), T.translation().y(), T.translation().z(),
                         q.x(), q.y(), q.z(), q.w()};
    for (int k = 0; k < 8; ++k) {
      if (k) out += ' ';
      io_detail::appendNumber(out, v[k]);
    }
    out += '\n';
  }
  writeTextAtomically(path, out);
}

}  // namespace hazmap
