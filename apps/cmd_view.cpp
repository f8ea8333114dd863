// hazmap view RUN_DIR: one self-contained HTML page showing the run's map in 3D.
#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "command.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/map/viewer.hpp"

namespace hazmap::cli {
namespace {

struct ViewOptions {
  std::string run_dir;
  std::string out;
  std::string classes = "default";
  std::size_t max_points = 0;
  double max_mb = 30.0;
  bool top = false;
};

void run(const ViewOptions& o) {
  if (!(o.max_mb > 0)) fail("--max-mb", "must be > 0");
  const ViewerScene scene = loadRunScene(o.run_dir, ClassTable::load(o.classes));
  ViewerConfig config;
  config.max_points = o.max_points;
  config.max_bytes = std::size_t(o.max_mb * 1048576.0);
  config.top_down_first = o.top;
  const std::filesystem::path out = o.out.empty() ? std::filesystem::path(o.run_dir) / "viewer.html" : std::filesystem::path(o.out);
  const ViewerReport r = writeViewer(out, scene, config);
  std::cout << fmt::format("wrote {} ({:.1f} MB, {} of {} map points, {} hazards): open it in a browser\n",
                           out.string(), double(r.bytes) / 1048576.0, r.points_embedded, r.points_total,
                           scene.hazards.size());
}

const RegisterCommand registration{{
    "view",
    "Write one self-contained HTML page (works offline) showing a run's map, hazards and trajectory in 3D",
    [](CLI::App& app) {
      auto o = std::make_shared<ViewOptions>();
      app.add_option("run_dir", o->run_dir, "A `hazmap run` output folder (map.ply, hazards.json, trajectory.kitti)")
          ->required();
      app.add_option("--out", o->out, "Page to write (default RUN_DIR/viewer.html)");
      app.add_option("--max-points", o->max_points, "Embed at most this many map points, evenly decimated (0 = all)");
      app.add_option("--max-mb", o->max_mb, "Refuse to write a page larger than this (MB)");
      app.add_option("--classes", o->classes, "Class table of the run: 'default', 'semantic-kitti' or a YAML file");
      app.add_flag("--top", o->top, "Open in the top-down view");
      app.callback([o] { run(*o); });
    }}};

}  // namespace
}  // namespace hazmap::cli
