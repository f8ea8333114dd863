#include "hazmap/graph/g2o.hpp"

#include <Eigen/Eigenvalues>

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <string_view>
#include <vector>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"

namespace hazmap {

namespace {

std::vector<std::string_view> splitTokens(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    if (i >= line.size()) break;
    std::size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
    tokens.push_back(line.substr(i, j - i));
    i = j;
  }
  return tokens;
}

struct LineParser {
  const std::string& name;
  int line = 0;

  [[noreturn]] void error(const std::string& what) const {
    fail(name + ":" + std::to_string(line), what);
  }
  double number(std::string_view token) const {
    double v = 0.0;
    const auto* end = token.data() + token.size();
    auto [ptr, ec] = std::from_chars(token.data(), end, v);
    if (ec != std::errc() || ptr != end)
      error("'" + std::string(token) + "' is not a number");
    if (!std::isfinite(v)) error("non-finite value '" + std::string(token) + "' (NaN or inf)");
    return v;
  }
  std::int64_t integer(std::string_view token) const {
    std::int64_t v = 0;
    const auto* end = token.data() + token.size();
    auto [ptr, ec] = std::from_chars(token.data(), end, v);
    if (ec != std::errc() || ptr != end || v < 0)
      error("'" + std::string(token) + "' is not a vertex id (non-negative integer)");
    return v;
  }
  void expectTokens(const std::vector<std::string_view>& t, std::size_t n) const {
    if (t.size() != n)
      error(std::string(t[0]) + " needs " + std::to_string(n) + " tokens, found " +
            std::to_string(t.size()));
  }
};

Eigen::Isometry3d poseFromQuat(const LineParser& p, const std::vector<std::string_view>& t,
                               std::size_t first) {
  double v[7];
  for (int k = 0; k < 7; ++k) v[k] = p.number(t[first + k]);
  Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  const double norm = q.norm();
  if (!(norm > 1e-6)) p.error("quaternion has zero norm");
  if (std::abs(norm - 1.0) > 1e-2) p.error("quaternion is not unit (norm " + fmt::format("{:.6g}", norm) + ")");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  return T;
}

template <int N>
bool positiveDefinite(const Eigen::Matrix<double, N, N>& m) {
  Eigen::LLT<Eigen::Matrix<double, N, N>> llt(m);
  if (llt.info() != Eigen::Success) return false;
  const double scale = m.cwiseAbs().maxCoeff();
  return llt.matrixL().toDenseMatrix().diagonal().minCoeff() > 1e-12 * std::sqrt(scale);
}

// An information matrix that is not positive definite, made usable as `policy` says (see
// G2oInformation); returns whether it changed.
template <int N>
bool makeUsable(Eigen::Matrix<double, N, N>& m, G2oInformation policy, const LineParser& p) {
  if (positiveDefinite(m)) return false;
  if (policy == G2oInformation::Strict) p.error("information matrix is not positive definite");
  if (policy == G2oInformation::DiagonalBlocks) {
    // Translation block and rotation block only: N = 6 is x y z | rx ry rz, N = 3 is x y | θ.
    const int t = N == 6 ? 3 : 2;
    m.topRightCorner(t, N - t).setZero();
    m.bottomLeftCorner(N - t, t).setZero();
    if (!positiveDefinite(m))
      p.error("information matrix's translation or rotation block is not positive definite");
    return true;
  }
  // Nearest positive-definite matrix (Frobenius norm): eigenvalues clamped to a small floor.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> eig(m);
  const double largest = eig.eigenvalues().maxCoeff();
  if (!(largest > 0.0)) p.error("information matrix has no positive eigenvalue");
  const Eigen::Matrix<double, N, 1> clamped = eig.eigenvalues().cwiseMax(1e-9 * largest);
  m = eig.eigenvectors() * clamped.asDiagonal() * eig.eigenvectors().transpose();
  m = 0.5 * (m + m.transpose()).eval();
  return true;
}

template <int N>
Eigen::Matrix<double, N, N> upperTriangle(const LineParser& p,
                                          const std::vector<std::string_view>& t,
                                          std::size_t first) {
  Eigen::Matrix<double, N, N> m;
  std::size_t k = first;
  for (int r = 0; r < N; ++r)
    for (int c = r; c < N; ++c) m(r, c) = m(c, r) = p.number(t[k++]);
  return m;
}

struct RawEdge {
  std::int64_t from, to;
  Eigen::Isometry3d T;
  Matrix6d info_right;
  int line;
};


// Every line of a g2o text, checked, before the graph is assembled.
struct G2oLines {
  int dimension = 0;
  std::vector<std::pair<std::int64_t, Eigen::Isometry3d>> vertices;
  std::map<std::int64_t, int> vertex_line;
  std::vector<RawEdge> raw;
  std::int64_t fix_id = -1;
  int fix_line = 0;
  std::vector<int> adjusted;  ///< lines whose information was changed (G2oInformation)
};

G2oLines readLines(const std::string& text, LineParser& p, G2oInformation policy) {
  G2oLines g;
  int& dimension = g.dimension;
  auto& vertices = g.vertices;
  auto& vertex_line = g.vertex_line;
  auto& raw = g.raw;
  auto& adjusted = g.adjusted;
  auto setDimension = [&](int d) {
    if (dimension != 0 && dimension != d) p.error("mixes 2-D and 3-D vertices/edges");
    dimension = d;
  };
  std::size_t pos = 0;
  while (pos <= text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    const std::string_view line(text.data() + pos, end - pos);
    pos = end + 1;
    ++p.line;
    const auto t = splitTokens(line);
    if (t.empty() || t[0][0] == '#') continue;
    const std::string_view tag = t[0];
    if (tag == "VERTEX_SE3:QUAT" || tag == "VERTEX_SE2") {
      const bool planar = tag == "VERTEX_SE2";
      setDimension(planar ? 2 : 3);
      p.expectTokens(t, planar ? 5 : 9);
      const std::int64_t id = p.integer(t[1]);
      if (vertex_line.count(id))
        p.error("duplicate vertex id " + std::to_string(id) + " (first on line " +
                std::to_string(vertex_line[id]) + ")");
      vertex_line[id] = p.line;
      Eigen::Isometry3d T =
          planar ? fromXyYaw(p.number(t[2]), p.number(t[3]), p.number(t[4])) : poseFromQuat(p, t, 2);
      vertices.emplace_back(id, T);
    } else if (tag == "EDGE_SE3:QUAT" || tag == "EDGE_SE2") {
      const bool planar = tag == "EDGE_SE2";
      setDimension(planar ? 2 : 3);
      p.expectTokens(t, planar ? 12 : 31);
      RawEdge e;
      e.from = p.integer(t[1]);
      e.to = p.integer(t[2]);
      e.line = p.line;
      if (e.from == e.to) p.error("edge joins vertex " + std::to_string(e.from) + " to itself");
      e.info_right.setZero();
      if (planar) {
        e.T = fromXyYaw(p.number(t[3]), p.number(t[4]), p.number(t[5]));
        Eigen::Matrix3d m = upperTriangle<3>(p, t, 6);
        if (makeUsable(m, policy, p)) adjusted.push_back(p.line);
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) e.info_right(kPlanarIndex[r], kPlanarIndex[c]) = m(r, c);
      } else {
        e.T = poseFromQuat(p, t, 3);
        e.info_right = upperTriangle<6>(p, t, 10);
        if (makeUsable(e.info_right, policy, p)) adjusted.push_back(p.line);
      }
      raw.push_back(e);
    } else if (tag == "FIX") {
      p.expectTokens(t, 2);
      g.fix_id = p.integer(t[1]);
      g.fix_line = p.line;
    } else {
      p.error("unknown tag '" + std::string(tag) + "'");
    }
  }
  return g;
}

}  // namespace

PoseGraph parseG2o(const std::string& text, const std::string& name, G2oReadInfo* info,
                   G2oInformation policy) {
  LineParser p{name};
  G2oLines lines = readLines(text, p, policy);
  const int dimension = lines.dimension;
  const auto& vertices = lines.vertices;
  const auto& raw = lines.raw;
  const std::int64_t fix_id = lines.fix_id;
  const int fix_line = lines.fix_line;
  auto& adjusted = lines.adjusted;
  if (dimension == 0) fail(name, "no vertices or edges (not a g2o pose graph)");

  PoseGraph graph;
  graph.dimension = dimension;
  std::map<std::int64_t, int> index;
  const bool had_vertices = !vertices.empty();
  if (had_vertices) {
    for (const auto& [id, T] : vertices) index[id] = graph.addNode(T, id);
  } else {
    std::vector<std::int64_t> ids;
    for (const auto& e : raw) {
      ids.push_back(e.from);
      ids.push_back(e.to);
    }
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    for (auto id : ids) index[id] = graph.addNode(Eigen::Isometry3d::Identity(), id);
  }
  for (const auto& e : raw) {
    p.line = e.line;
    for (auto id : {e.from, e.to})
      if (!index.count(id)) p.error("edge to missing vertex " + std::to_string(id));
    const EdgeKind kind = std::llabs(e.to - e.from) == 1 ? EdgeKind::Odometry : EdgeKind::Loop;
    try {
      graph.addEdge(index[e.from], index[e.to], e.T, informationRightToLeft(e.T, e.info_right),
                    kind);
    } catch (const Error& err) {
      p.error(err.what());
    }
  }
  if (fix_id >= 0) {
    p.line = fix_line;
    if (!index.count(fix_id)) p.error("FIX names missing vertex " + std::to_string(fix_id));
    graph.fixed_node = index[fix_id];
  }
  if (!had_vertices) initialiseFromOdometry(graph);
  if (info) {
    info->had_vertices = had_vertices;
    info->vertex_lines = static_cast<int>(vertices.size());
    info->edge_lines = static_cast<int>(raw.size());
    info->adjusted_lines = std::move(adjusted);
  }
  return graph;
}

PoseGraph readG2o(const std::filesystem::path& path, G2oReadInfo* info, G2oInformation policy) {
  return parseG2o(readTextFile(path), path.string(), info, policy);
}

std::string formatG2o(const PoseGraph& graph) {
  fmt::memory_buffer out;
  auto it = std::back_inserter(out);
  const bool planar = graph.dimension == 2;
  for (int i = 0; i < graph.numNodes(); ++i) {
    const Eigen::Isometry3d& T = graph.poses[i];
    const Eigen::Vector3d t = T.translation();
    if (planar) {
      fmt::format_to(it, "VERTEX_SE2 {} {} {} {}\n", graph.ids[i], t.x(), t.y(), yawOf(T));
    } else {
      const Eigen::Quaterniond q(T.linear());
      fmt::format_to(it, "VERTEX_SE3:QUAT {} {} {} {} {} {} {} {}\n", graph.ids[i], t.x(), t.y(),
                     t.z(), q.x(), q.y(), q.z(), q.w());
    }
  }
  for (const auto& e : graph.edges) {
    // Back to the file's (right-perturbation) form. The left↔right conversion is exact up to
    // rounding: print 15 digits and drop entries at the rounding level of the matrix, so a file
    // read and written again keeps its clean numbers (10, not 9.999999999999998 and 4e-16).
    // An edge through a bias node (PoseGraphEdge::bias): g2o files hold no bias nodes, so the
    // edge's marginal information (its own part and the shared one) is written.
    Matrix6d info = informationLeftToRight(e.T_from_to, e.information);
    const double noise = 1e-13 * info.cwiseAbs().maxCoeff();
    info = info.unaryExpr([noise](double v) { return std::abs(v) < noise ? 0.0 : v; });
    const Eigen::Vector3d t = e.T_from_to.translation();
    if (planar) {
      fmt::format_to(it, "EDGE_SE2 {} {} {} {} {}", graph.ids[e.from], graph.ids[e.to], t.x(),
                     t.y(), yawOf(e.T_from_to));
      for (int r = 0; r < 3; ++r)
        for (int c = r; c < 3; ++c)
          fmt::format_to(it, " {:.15g}", info(kPlanarIndex[r], kPlanarIndex[c]));
    } else {
      const Eigen::Quaterniond q(e.T_from_to.linear());
      fmt::format_to(it, "EDGE_SE3:QUAT {} {} {} {} {} {} {} {} {}", graph.ids[e.from],
                     graph.ids[e.to], t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
      for (int r = 0; r < 6; ++r)
        for (int c = r; c < 6; ++c) fmt::format_to(it, " {:.15g}", info(r, c));
    }
    fmt::format_to(it, "\n");
  }
  if (graph.fixed_node != 0 && graph.fixed_node < graph.numNodes())
    fmt::format_to(it, "FIX {}\n", graph.ids[graph.fixed_node]);
  return fmt::to_string(out);
}

void writeG2o(const std::filesystem::path& path, const PoseGraph& graph) {
  writeTextAtomically(path, formatG2o(graph));
}

}  // namespace hazmap
