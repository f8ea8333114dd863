#pragma once
// PNG renders for people, drawn with Cairo (anti-aliased, DejaVu Sans text): a top-down map with
// hazards, the trajectory, axes in metres, a legend and a scale bar (map_top.png), the
// trajectory comparison plot like the paper's Fig. 7 (trajectory.png), the trajectory error
// against distance travelled for several methods (`hazmap eval --plot`), and a titled montage
// of several top-down maps (the demo's five methods side by side).
#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/map/export.hpp"
#include "hazmap/map/hazards.hpp"
#include "hazmap/map/image.hpp"

namespace hazmap {

/// World-frame rectangle in x/y (metres).
struct ViewBox {
  Eigen::Vector2d min = Eigen::Vector2d::Zero(), max = Eigen::Vector2d::Zero();
};

struct TopDownConfig {
  double pixels_per_metre = 20.0;  ///< reduced automatically to respect max_size_px
  int max_size_px = 1600;          ///< longest image side of the map area
  int margin_px = 24;          ///< around the map area, besides the axis labels
  /// Points with world z above this are not drawn (e.g. ceilings hiding an indoor map);
  /// nullopt = draw everything.
  std::optional<double> clip_above;
  /// Size (m) of the map's cells (GlobalMap::voxelSize()): each point then fills its cell's
  /// footprint, so the render has no holes at high zoom. 0 = one pixel per point.
  double cell_size = 0.0;
  int property_point_px = 2;   ///< property points are drawn at least (2·this − 1) px wide
  bool draw_axes = true;       ///< x/y ticks in metres around the map
  /// With hazards given, only property cells inside a hazard are coloured; isolated ones (too
  /// small to be a hazard, usually false labels) are drawn like plain cells.
  bool hazard_cells_only = true;
  bool draw_hazard_labels = true;
  bool draw_legend = true;
  bool draw_scale_bar = true;
  std::string title;           ///< drawn in a band above the map when not empty
  std::optional<ViewBox> view; ///< fixed extent (montages use one box for all panels)
  Rgb background{255, 255, 255};
  Rgb trajectory{128, 0, 170};  ///< purple, as the paper's Fig. 6
  MapColorConfig colors;
};

/// Where the map area of a top-down render lies in its image.
struct TopDownFrame {
  ViewBox view;
  double pixels_per_metre = 1.0;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  ///< pixel of the view's (min x, max y) corner
  Eigen::Vector2d pixelOf(double x, double y) const {
    return origin + pixels_per_metre * Eigen::Vector2d(x - view.min.x(), view.max.y() - y);
  }
};

/// Top-down render: plain points grey by the highest point per pixel, property cells in their
/// hazard colour on top, hazards ringed and numbered (ids of `hazards`), the trajectory as a
/// line from a green start dot to a black end square, axes in metres, a scale bar and a legend.
/// `frame` (optional) receives where the map lies in the image.
Image renderTopDown(const LabeledCloud& map, const ClassTable& table,
                    const std::vector<Eigen::Vector3d>& trajectory,
                    const std::vector<Hazard>& hazards = {}, const TopDownConfig& config = {},
                    TopDownFrame* frame = nullptr);

/// x/y bounds of a map and a trajectory, with `pad` metres around (for shared montage views).
ViewBox viewOf(const LabeledCloud& map, const std::vector<Eigen::Vector3d>& trajectory, double pad = 1.0);
ViewBox unite(const ViewBox& a, const ViewBox& b);

struct PlotSeries {
  std::string label;
  std::vector<Eigen::Vector3d> positions;
  Rgb color{0, 0, 0};
  double thickness = 2.0;  ///< line width in pixels
};

struct TrajectoryPlotConfig {
  int width = 1400, height = 700;  ///< whole image
  std::string title = "Trajectory (top view)";
  std::string error_title = "Translation error vs ground truth";
};

/// Two panels like the paper's Fig. 7: left, the series top-down on equal axes with a grid,
/// ticks in metres and a legend; right (when `errors` is not empty), each series' translation
/// error per frame. errors[k] belongs to the series with the same label (label, values).
Image renderTrajectoryPlot(const std::vector<PlotSeries>& series,
                           const std::vector<std::pair<PlotSeries, std::vector<double>>>& errors = {},
                           const TrajectoryPlotConfig& config = {});

/// trajectory.png in one call: estimate (blue), ground truth (black, optional) and odometry
/// (orange, optional) top-down, plus their translation error per frame against the ground truth
/// when it is given (frames compared one to one; lengths must match).
Image renderTrajectoryComparison(const Trajectory& estimate, const Trajectory* ground_truth,
                                 const Trajectory* odometry, const TrajectoryPlotConfig& config = {});

struct MontagePanel {
  std::string title;
  Image image;
};
struct MontageConfig {
  int columns = 0;  ///< 0 = automatic (up to 3 per row)
  int gap_px = 16;
  double panel_title_size = 18;  ///< font size (px) of each panel's title
  double title_size = 24;        ///< font size (px) of the montage's title
  std::string title;  ///< over the whole montage
  Rgb background{255, 255, 255};
};
Image renderMontage(const std::vector<MontagePanel>& panels, const MontageConfig& config = {});

/// One top-down map per method with a shared view and pixel scale, titled, in a montage.
struct MapPanel {
  std::string title;
  const LabeledCloud* map = nullptr;
  std::vector<Eigen::Vector3d> trajectory;
  std::vector<Hazard> hazards;
};
Image renderMapMontage(const std::vector<MapPanel>& panels, const ClassTable& table,
                       TopDownConfig config = {}, const MontageConfig& montage = {});

/// One method's translation error against distance travelled along the ground truth.
struct ErrorSeries {
  std::string label;
  std::vector<double> distance_m;  ///< distance travelled at each pose
  std::vector<double> error_m;     ///< translation error at each pose
  Rgb color{0, 0, 0};
};
struct ErrorPlotConfig {
  int width = 1200, height = 600;
  std::string title = "Trajectory error vs distance travelled";
};
/// Error curves of several methods on shared axes (metres against metres), with a legend that
/// gives each one's mean error. Throws hazmap::Error on no series or mismatched lengths.
Image renderErrorPlot(const std::vector<ErrorSeries>& series, const ErrorPlotConfig& config = {});
/// Distance travelled at each pose (0 at the first).
std::vector<double> distanceTravelled(const Trajectory& trajectory);
/// A palette of distinguishable colours for series k.
Rgb seriesColor(std::size_t k);

/// Positions of a trajectory.
std::vector<Eigen::Vector3d> positionsOf(const Trajectory& trajectory);

}  // namespace hazmap
