#include "pipeline/edge_journal.hpp"

#include <algorithm>

#include "hazmap/core/journaled_list.hpp"

namespace hazmap::pipeline_detail {

namespace {

// An edge as doubles: from, to, kind (small integers, exact), then the measurement and the
// information as the journaled lists write them (core/journaled_list.hpp's codecs).
using PoseCodec = JournalCodec<Eigen::Isometry3d>;
using InformationCodec = JournalCodec<Matrix6d>;
constexpr std::size_t kInformationAt = 3 + PoseCodec::kDoubles;
constexpr std::size_t kDoubles = kInformationAt + InformationCodec::kDoubles;

void put(const PoseGraphEdge& e, double* d) {
  d[0] = e.from;
  d[1] = e.to;
  d[2] = static_cast<double>(e.kind);
  PoseCodec::put(e.T_from_to, d + 3);
  InformationCodec::put(e.information, d + kInformationAt);
}

PoseGraphEdge get(const double* d) {
  PoseGraphEdge e;
  e.from = static_cast<int>(d[0]);
  e.to = static_cast<int>(d[1]);
  e.kind = static_cast<EdgeKind>(static_cast<int>(d[2]));
  e.T_from_to = PoseCodec::get(d + 3);
  e.information = InformationCodec::get(d + kInformationAt);
  return e;
}

}  // namespace

void EdgeJournal::journalBefore(PoseGraph& graph, std::size_t keep_from, std::size_t batch) {
  const auto kept = std::find_if(graph.edges.begin(), graph.edges.end(), [&](const PoseGraphEdge& e) {
    return e.kind == EdgeKind::Odometry && static_cast<std::size_t>(e.to) >= keep_from;
  });
  const auto n = static_cast<std::size_t>(kept - graph.edges.begin());
  if (n == 0 || n < batch) return;
  if (!file_) file_ = std::make_unique<JournalFile>("pose graph edge journal");
  std::vector<double> bytes(n * kDoubles);
  for (std::size_t i = 0; i < n; ++i) put(graph.edges[i], bytes.data() + i * kDoubles);
  file_->append(bytes.data(), bytes.size() * sizeof(double));
  graph.edges.erase(graph.edges.begin(), kept);
  count_ += n;
  // After a restore the list's block holds the whole graph: give it back.
  if (graph.edges.capacity() > 4 * std::max(graph.edges.size(), batch)) graph.edges.shrink_to_fit();
}

std::vector<PoseGraphEdge> EdgeJournal::journaled() const {
  std::vector<PoseGraphEdge> out;
  if (count_ == 0) return out;
  std::vector<double> bytes(count_ * kDoubles);
  file_->read(0, bytes.data(), bytes.size() * sizeof(double));
  out.reserve(count_);
  for (std::size_t i = 0; i < count_; ++i) out.push_back(get(bytes.data() + i * kDoubles));
  return out;
}

void EdgeJournal::restore(PoseGraph& graph) {
  if (count_ == 0) return;
  std::vector<PoseGraphEdge> edges = journaled();
  edges.insert(edges.end(), graph.edges.begin(), graph.edges.end());
  graph.edges = std::move(edges);
  file_->clear();
  count_ = 0;
}

std::vector<PoseGraphEdge> EdgeJournal::allEdges(const PoseGraph& graph) const {
  std::vector<PoseGraphEdge> edges = journaled();
  edges.insert(edges.end(), graph.edges.begin(), graph.edges.end());
  return edges;
}

}  // namespace hazmap::pipeline_detail
