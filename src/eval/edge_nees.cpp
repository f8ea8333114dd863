#include "hazmap/eval/edge_nees.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {

// 95 % quantiles of χ²(3) and χ²(6).
double chiSquare95(int dof) { return dof == 3 ? 7.814727903 : 12.591587243; }

// Quantile by linear interpolation between order statistics (sorted input).
double quantile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0.0;
  const double pos = q * static_cast<double>(sorted.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (pos - static_cast<double>(lo)) * (sorted[hi] - sorted[lo]);
}

EdgeNees neesOf(const PoseGraphEdge& edge, const Eigen::Isometry3d& T_true_ij, int dimension) {
  EdgeNees n;
  n.from = edge.from;
  n.to = edge.to;
  n.kind = edge.kind;
  n.error = edgeError(edge.T_from_to, T_true_ij);
  if (dimension == 2) {
    Eigen::Matrix3d info;
    Eigen::Vector3d e;
    for (int r = 0; r < 3; ++r) {
      e(r) = n.error(kPlanarIndex[r]);
      for (int c = 0; c < 3; ++c) info(r, c) = edge.information(kPlanarIndex[r], kPlanarIndex[c]);
    }
    n.nees = e.dot(info * e);
    const Eigen::Matrix3d cov = info.inverse();
    for (int r = 0; r < 3; ++r) n.axis_nees[kPlanarIndex[r]] = e(r) * e(r) / cov(r, r);
    return n;
  }
  n.nees = n.error.dot(edge.information * n.error);
  const Matrix6d cov = edge.information.inverse();
  for (int k = 0; k < 6; ++k) n.axis_nees[k] = n.error(k) * n.error(k) / cov(k, k);
  return n;
}

/// summariseNees over edges held by value (span chains).
NeesStats summariseOwned(const std::vector<EdgeNees>& edges, int dof) {
  std::vector<const EdgeNees*> ptrs;
  ptrs.reserve(edges.size());
  for (const EdgeNees& e : edges) ptrs.push_back(&e);
  return summariseNees(ptrs, dof);
}

nlohmann::json statsJson(const NeesStats& s) {
  return {{"count", s.count}, {"dof", s.dof}, {"mean", s.mean}, {"median", s.median}, {"p95", s.p95},
          {"max", s.max}, {"within_95", s.within_95}, {"axis_mean", s.axis_mean}};
}

const char* kindName(EdgeKind kind) {
  return kind == EdgeKind::Loop ? "loop" : kind == EdgeKind::MapAnchor ? "map_anchor" : "odometry";
}

}  // namespace

Vector6d edgeError(const Eigen::Isometry3d& T_measured, const Eigen::Isometry3d& T_true) {
  // Left perturbation: T_true = exp(ξ) · T_measured.
  return se3Log(T_true * T_measured.inverse());
}

EdgeNeesReport computeEdgeNees(const PoseGraph& graph, std::span<const Eigen::Isometry3d> truth,
                               const std::string& where) {
  if (truth.size() != graph.poses.size())
    fail(where, fmt::format("{} true poses for a graph of {} nodes", truth.size(), graph.poses.size()));
  for (std::size_t i = 0; i < truth.size(); ++i)
    if (!isFinite(truth[i])) fail(where, fmt::format("true pose {} is not finite", i));
  EdgeNeesReport report;
  report.edges.reserve(graph.edges.size());
  for (const PoseGraphEdge& edge : graph.edges) {
    if (edge.from < 0 || edge.to < 0 || edge.from >= graph.numNodes() || edge.to >= graph.numNodes())
      fail(where, fmt::format("edge {}-{} joins a node the graph does not have", edge.from, edge.to));
    const Eigen::Isometry3d T_true_ij = truth[static_cast<std::size_t>(edge.from)].inverse() * truth[static_cast<std::size_t>(edge.to)];
    report.edges.push_back(neesOf(edge, T_true_ij, graph.dimension));
  }
  const int dof = graph.dimension == 2 ? 3 : 6;
  std::vector<const EdgeNees*> odometry, loop, anchor, all;
  for (const EdgeNees& e : report.edges) {
    (e.kind == EdgeKind::Loop ? loop : e.kind == EdgeKind::MapAnchor ? anchor : odometry).push_back(&e);
    all.push_back(&e);
  }
  report.odometry = summariseNees(odometry, dof);
  report.loop = summariseNees(loop, dof);
  report.map_anchor = summariseNees(anchor, dof);
  report.all = summariseNees(all, dof);
  return report;
}

NeesStats summariseNees(const std::vector<const EdgeNees*>& edges, int dof) {
  NeesStats s;
  s.dof = dof;
  s.count = edges.size();
  if (edges.empty()) return s;
  std::vector<double> values;
  values.reserve(edges.size());
  const double bound = chiSquare95(dof);
  std::size_t inside = 0;
  for (const EdgeNees* e : edges) {
    values.push_back(e->nees);
    s.mean += e->nees;
    inside += e->nees <= bound ? 1 : 0;
    for (int k = 0; k < 6; ++k) s.axis_mean[k] += e->axis_nees[k];
  }
  const double n = static_cast<double>(edges.size());
  s.mean /= n;
  for (double& a : s.axis_mean) a /= n;
  s.within_95 = static_cast<double>(inside) / n;
  std::sort(values.begin(), values.end());
  s.median = quantile(values, 0.5);
  s.p95 = quantile(values, 0.95);
  s.max = values.back();
  return s;
}

NeesStats odometrySpanNees(const PoseGraph& graph, std::span<const Eigen::Isometry3d> truth, int span) {
  const int dof = graph.dimension == 2 ? 3 : 6;
  if (span < 1 || truth.size() != graph.poses.size()) fail("span NEES", "needs span >= 1 and one true pose per node");
  std::vector<const PoseGraphEdge*> into(graph.poses.size(), nullptr);  // odometry edge k−1 → k
  for (const PoseGraphEdge& e : graph.edges)
    if (e.kind == EdgeKind::Odometry && e.to == e.from + 1) into[static_cast<std::size_t>(e.to)] = &e;
  std::vector<EdgeNees> spans;
  for (std::size_t i = 0; i + static_cast<std::size_t>(span) < graph.poses.size(); i += static_cast<std::size_t>(span)) {
    PoseGraphEdge chained;
    chained.from = static_cast<int>(i);
    chained.to = static_cast<int>(i) + span;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    Matrix6d cov = Matrix6d::Zero();
    bool complete = true;
    for (std::size_t k = i + 1; k <= i + static_cast<std::size_t>(span) && complete; ++k) {
      complete = into[k] != nullptr;
      if (!complete) break;
      const Matrix6d Ad = adjoint(T);
      cov += Ad * into[k]->information.inverse() * Ad.transpose();
      T = T * into[k]->T_from_to;
    }
    if (!complete) continue;
    chained.T_from_to = T;
    chained.information = cov.inverse();
    spans.push_back(neesOf(chained, truth[i].inverse() * truth[i + static_cast<std::size_t>(span)], graph.dimension));
  }
  return summariseOwned(spans, dof);
}

std::string toJson(const NeesStats& stats) { return statsJson(stats).dump(); }

std::string toJson(const EdgeNeesReport& report, bool per_edge) {
  nlohmann::json j = {{"convention", "e = se3Log(T_true_ij * T_measured_ij^-1), NEES = e^T Omega e (left perturbation, translation first)"},
                      {"odometry", statsJson(report.odometry)},
                      {"loop", statsJson(report.loop)},
                      {"map_anchor", statsJson(report.map_anchor)},
                      {"all", statsJson(report.all)}};
  if (per_edge) {
    nlohmann::json edges = nlohmann::json::array();
    for (const EdgeNees& e : report.edges)
      edges.push_back({{"from", e.from}, {"to", e.to}, {"kind", kindName(e.kind)}, {"nees", e.nees},
                       {"error", std::vector<double>(e.error.data(), e.error.data() + 6)},
                       {"axis_nees", e.axis_nees}});
    j["edges"] = edges;
  }
  return j.dump(2);
}

std::string toText(const EdgeNeesReport& report) {
  std::string s = fmt::format("edge NEES against the truth (honest: mean {}, median {:.2f}, 95 % within {:.1f})\n",
                              report.all.dof, report.all.dof == 3 ? 2.37 : 5.35, chiSquare95(report.all.dof));
  s += fmt::format("{:<9} {:>6} {:>10} {:>10} {:>10} {:>10} {:>8}   per axis mean [x y z rx ry rz]\n", "edges",
                   "count", "mean", "median", "p95", "max", "in 95%");
  for (const auto& [name, st] : {std::pair{"odometry", &report.odometry}, std::pair{"loop", &report.loop},
                                 std::pair{"anchor", &report.map_anchor}, std::pair{"all", &report.all}}) {
    s += fmt::format("{:<9} {:>6} {:>10.3f} {:>10.3f} {:>10.3f} {:>10.3f} {:>7.1f}%   ", name, st->count, st->mean,
                     st->median, st->p95, st->max, 100.0 * st->within_95);
    for (double a : st->axis_mean) s += fmt::format(" {:.2f}", a);
    s += "\n";
  }
  return s;
}

}  // namespace hazmap
