// hazmap noise-sweep: the demo over a grid of crawler-odometry noise and frame spacing
// (demo/noise_sweep.hpp): where does property ICP beat plain ICP?
#include <iostream>
#include <memory>

#include "command.hpp"
#include "hazmap/demo/noise_sweep.hpp"

namespace hazmap::cli {
namespace {

struct SweepOptions {
  std::string out = "hazmap-noise-sweep";
  std::string seeds = "1";
  std::vector<std::string> axes, points, base;
};

const RegisterCommand registration{{
    "noise-sweep",
    "The demo's five methods over simulator odometry noise (slip probability and size) and frame "
    "spacing: table and plot of where property ICP beats ICP",
    [](CLI::App& app) {
      auto o = std::make_shared<SweepOptions>();
      auto c = std::make_shared<NoiseSweepConfig>();
      c->demo.camera_labels = false;
      c->demo.progress = false;
      app.add_option("--out", o->out, "Output folder (one demo folder per point; re-running reuses finished points)");
      app.add_option("--scenario", c->demo.scenario, "Simulated scenario (naraha, corridor, tanks)");
      app.add_option("--seeds", o->seeds, "Seeds per point (1-3, 1,3,5)");
      app.add_option("--frames", c->demo.frames, "Use only the first N frames (0 = whole route)");
      app.add_option("--threads", c->demo.threads, "Worker threads (0 = all cores)");
      app.add_flag("!--paper-only", c->demo.frame_to_map, "Only the paper's set-up (no frame-to-map runs)");
      app.add_option("--axis", o->axes,
                     "One axis varied from the defaults: KEY=V1,V2,... or KEY1:KEY2=A1:B1,A2:B2 (keys varied "
                     "together), e.g. odometry.slip_probability=0,0.08,0.3 (repeatable)");
      app.add_option("--point", o->points,
                     "A named combination: NAME@KEY=V;KEY=V, e.g. 'big slips@odometry.slip_min=1;odometry.slip_max=2' "
                     "(repeatable)");
      app.add_option("--base", o->base, "Simulator setting under every point, KEY=V (repeatable)");
      app.callback([o, c] {
        c->demo.out_dir = o->out;
        c->seeds = parseSeedList(o->seeds);
        for (const auto& a : o->axes) c->axes.push_back(parseSweepAxis(a));
        for (const auto& p : o->points) c->combinations.push_back(parseSweepCombination(p));
        c->base = o->base;
        runNoiseSweep(*c, std::cout);
      });
    }}};

}  // namespace
}  // namespace hazmap::cli
