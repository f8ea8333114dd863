#pragma once
// The oldest edges of a run's pose graph in a journal file (issue 33: an odometry edge is ~430
// bytes, a node per frame, ~16 MB an hour at 10 scans/s; only an optimisation, a save or the end
// reads the old ones). What goes is always a prefix of graph.edges that stops before the newest
// frames' odometry edges (re-estimating lost frames rewrites those); everything that touches older
// edges — replacing the loop edges, refreshing the anchors' information, the solve, a snapshot —
// works on the graph restored whole, the journal's edges in front in their order, so the graph is
// the one never journaled, edge for edge and bit for bit.
#include <cstddef>
#include <memory>
#include <vector>

#include "hazmap/core/journal_file.hpp"
#include "hazmap/graph/pose_graph.hpp"

namespace hazmap::pipeline_detail {

class EdgeJournal {
 public:
  /// Moves the edges before the odometry edge into frame `keep_from` to the journal once there
  /// are at least `batch` of them. Opens the journal (TMPDIR) the first time.
  void journalBefore(PoseGraph& graph, std::size_t keep_from, std::size_t batch);
  /// graph.edges = the journal's edges, then the graph's own; the journal is empty after.
  void restore(PoseGraph& graph);
  /// Every edge (the journal's, then the graph's), the graph left as it is.
  std::vector<PoseGraphEdge> allEdges(const PoseGraph& graph) const;
  std::size_t size() const { return count_; }

 private:
  std::vector<PoseGraphEdge> journaled() const;

  std::unique_ptr<JournalFile> file_;
  std::size_t count_ = 0;
};

}  // namespace hazmap::pipeline_detail
