// hazmap demo: the README's main job (the paper's Table 2 from one command); `--live`: the live
// view in one command (simulate → replay on loopback → live, demo_live.hpp).
#include <iostream>
#include <memory>

#include "command.hpp"
#include "config_options.hpp"
#include "demo_live.hpp"
#include "hazmap/demo/demo.hpp"
#include "hazmap/demo/demo_seeds.hpp"

namespace hazmap::cli {
namespace {

const RegisterCommand registration{{
    "demo",
    "Simulate the paper's experiment (naraha), run the five methods and print Table 2",
    [](CLI::App& app) {
      auto o = std::make_shared<DemoConfig>();
      auto out = std::make_shared<std::string>(o->out_dir.string());
      auto seeds = std::make_shared<std::string>();
      app.add_option("--out", *out, "Output folder");
      app.add_option("--scenario", o->scenario, "Simulated scenario (naraha, corridor, tanks)");
      auto* seed = app.add_option("--seed", o->seed, "Simulator seed");
      app.add_option("--seeds", *seeds,
                     "Several seeds (1-8, 1,3,5): one demo folder per seed (OUT/seed-N/) and Table 2 as "
                     "mean ± sd over them in OUT/table2.json")
          ->excludes(seed);
      app.add_option("--sim-set", o->simulator_settings,
                     "Simulator setting section.key=value over its defaults, e.g. odometry.slip_probability=0.3 "
                     "or robot.frame_distance=0.5 (repeatable)");
      app.add_option("--frames", o->frames, "Use only the first N frames (0 = whole route)");
      app.add_option("--threads", o->threads, "Worker threads (0 = all cores)");
      app.add_flag("!--paper-only", o->frame_to_map,
                   "Only the paper's set-up (skip the frame-to-map tracking runs)");
      app.add_flag("!--no-camera-labels", o->camera_labels,
                   "Skip the rows with labels from the simulated thermal camera");
      auto live = std::make_shared<LiveDemoOptions>();
      auto live_flag = std::make_shared<bool>(false);
      app.add_flag("--live", *live_flag,
                   "The live view instead: simulate the mission as VLP-16 packets, replay them on loopback to "
                   "hazmap live, print the page's address; the run folder goes to OUT/live");
      app.add_option("--rate", live->rate, "With --live: replay speed over the simulated clock (frames are 10 s apart)");
      addLiveViewOptions(app, live->live);
      auto params = addParameterOptions(app, "run settings for every method, as in `hazmap run --config`");
      app.callback([o, out, params, seeds, live, live_flag] {
        if (*live_flag) {
          live->scenario = o->scenario;
          live->seed = o->seed;
          live->frames = o->frames;
          live->live.out = *out;
          live->live.threads = o->threads;
          return runLiveDemo(*live, *params);
        }
        o->out_dir = *out;
        o->property_icp = params->propertyIcp();
        o->settings = params->settings;
        if (!seeds->empty())
          runDemoSeeds(*o, parseSeedList(*seeds), std::cout);
        else
          runDemo(*o, std::cout);
      });
    }}};

}  // namespace
}  // namespace hazmap::cli
