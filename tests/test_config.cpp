// The one config mechanism (core/config_fields.hpp): defaults, round trips, errors that name the
// file and the key, --set, the property-ICP parameters and the generated reference page.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "hazmap/core/config_fields.hpp"
#include "hazmap/core/property_icp_config.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/map/global_map.hpp"
#include "hazmap/map/hazards.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "hazmap/sim/simulator.hpp"
#include "odometry/odometry_checks.hpp"
#include "pipeline/loop_edges.hpp"
#include "test_helpers.hpp"

using namespace hazmap;

namespace {

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

// The defaults the tables print (YAML text, shortest round-trip numbers) read back into a struct
// whose every field was first changed give exactly the struct's default member initialisers:
// every field is in the table, and every default survives the text.
template <typename S>
void expectDefaultsRoundTrip(const S& defaults, S changed) {
  const std::string yaml = configToYaml(defaults);
  ASSERT_NE(configToJson(changed), configToJson(defaults)) << "the changed struct must differ";
  fieldsOf<S>().read(changed, YAML::Load(yaml), ConfigPlace{"defaults", ""});
  EXPECT_EQ(configToJson(changed).dump(), configToJson(defaults).dump());
  EXPECT_EQ(configToYaml(changed), yaml);
  // And the described defaults are the struct's.
  // (A field written only in some cases, e.g. the simulator's scene file, is described always.)
  const nlohmann::json written = configToJson(defaults);
  nlohmann::json described = nlohmann::json::object();
  for (const auto& f : describeConfig(defaults))
    if (written.contains(f.name)) described[f.name] = f.default_value;
  EXPECT_EQ(described.dump(), configToJson(defaults).dump());
}

}  // namespace

TEST(ConfigFields, DefaultsEqualTheStructsInitialisersAndRoundTrip) {
  RegistrationConfig r;
  r.use_classes = false, r.metric = IcpMetric::PointToPoint, r.max_correspondence_distance = 2.5;
  r.max_iterations = 7, r.label_mode = LabelMode::Soft, r.label_confidence = 0.5;
  r.use_class_weights = false, r.property_weight = 0.3, r.property_point_to_point = false;
  r.property_tangent_weight = 0.7, r.min_label_agreement = -1, r.min_label_pairs = 3;
  r.robust_kernel = RobustKernel::Huber, r.robust_scale_factor = 2, r.robust_min_scale = 0.2;
  r.translation_tolerance = 0.1, r.rotation_tolerance = 0.1, r.correspondence_reuse_distance = 0;
  r.min_correspondences = 7, r.normal_neighbors = 5, r.normal_radius = 2, r.index = SpatialIndexKind::KdTree;
  r.index_cell_size = 0.3, r.max_source_points = 9, r.coarse_source_points = 0, r.threads = 2;
  r.degeneracy_threshold = 0.5, r.degeneracy_length = 3;
  expectDefaultsRoundTrip(RegistrationConfig{}, r);

  OdometryConfig o;
  o.mode = OdometryMode::FrameToFrame, o.registration = r, o.min_range = 2, o.max_range = 50;
  o.voxel_size = 0.2, o.source_voxel_size = 0.4, o.map.voxel_size = 3, o.map.max_points_per_voxel = 2;
  o.map.min_point_distance = 0.1, o.map.max_distance = 9, o.map.normal_updates = 4, o.min_fitness = 0.9;
  o.max_correction_translation = 3, o.max_correction_rotation = 0.9;
  o.fallback_sigma_translation = 0.7, o.fallback_sigma_rotation = 0.7;
  o.recovery.relocalise = false, o.recovery.relocalise_suspect = true, o.recovery.max_translation = 1;
  o.recovery.max_rotation = 0.3, o.recovery.whole_map = false, o.recovery.whole_map_after = 7;
  o.recovery.keyframe_distance = 5, o.recovery.keyframe_rotation = 1, o.recovery.reestimate_lost_frames = false;
  o.recovery.lost_frames_max = 9, o.label_axis.search = false, o.label_axis.range = 1.5;
  o.global.voxel_size = 0.3, o.global.refinement.max_iterations = 9;
  expectDefaultsRoundTrip(OdometryConfig{}, o);

  // Every field of the whole run (nested sections included) round-trips its defaults exactly.
  const SlamConfig run = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  SlamConfig other = SlamConfig::forMethod(SlamMethod::IcpPgo);
  other.odometry = o;
  expectDefaultsRoundTrip(run, other);
  SlamConfig reread = SlamConfig::forMethod(SlamMethod::Icp);
  reread.applyYamlString(configToYaml(run), "dump.yaml");
  EXPECT_EQ(configToJson(reread), configToJson(run));

  sim::SimulatorConfig s;
  s.seed = 9, s.sensor.channels = 32, s.robot.max_speed = 0.3, s.temperature.enabled = true;
  expectDefaultsRoundTrip(sim::SimulatorConfig{}, s);
  GlobalMapConfig m;
  m.voxel_size = 0.4, m.max_voxels = 5000, m.min_range = 1, m.max_range = 9, m.max_frame_ranges = 3;
  expectDefaultsRoundTrip(GlobalMapConfig{}, m);
  HazardConfig h;
  h.link_cells = 1, h.min_cells = 5, h.min_points = 1;
  expectDefaultsRoundTrip(HazardConfig{}, h);
}

TEST(ConfigFields, SectionDefaultsComeFromTheParent) {
  // Loop verification's ICP has its own defaults (wider search, k-d tree): the described
  // defaults of a nested section are the parent's member, not the nested struct's.
  const auto top = describeConfig<LoopClosureConfig>();
  const auto ver = std::find_if(top.begin(), top.end(), [](const FieldInfo& f) { return f.name == "verification"; });
  ASSERT_NE(ver, top.end());
  EXPECT_EQ(ver->default_value["registration"]["max_correspondence_distance"], 1.5);
  EXPECT_EQ(ver->default_value["registration"]["index"], "kdtree");
  EXPECT_EQ(configToJson(RegistrationConfig{})["index"], "voxel");
}

TEST(ConfigFields, ErrorsNameTheFileAndTheKey) {
  EXPECT_EQ(errorOf([] { odometryConfigFromYaml("registration: {max_correspondence_distance: -1}\n", "odo.yaml"); }),
            "odo.yaml: odometry.registration.max_correspondence_distance: must be > 0, got -1");
  EXPECT_EQ(errorOf([] { odometryConfigFromYaml("odometry:\n  registration:\n    max_iteration: 3\n", "odo.yaml"); }),
            "odo.yaml: odometry.registration: unknown key 'max_iteration' (did you mean 'max_iterations'?)");
  EXPECT_EQ(errorOf([] { registrationConfigFromYaml("metric: triangle\n", "r.yaml"); }),
            "r.yaml: registration.metric: must be one of plane | point, got 'triangle'");
  EXPECT_EQ(errorOf([] { registrationConfigFromYaml("max_iterations: 2.5\n", "r.yaml"); }),
            "r.yaml: registration.max_iterations: must be a whole number, got '2.5'");
  EXPECT_EQ(errorOf([] { registrationConfigFromYaml("coarse_source_points: 5\n", "r.yaml"); }),
            "r.yaml: registration.coarse_source_points: must be 0 (off) or >= min_correspondences");
  EXPECT_EQ(errorOf([] { registrationConfigFromYaml("max_iterations: [1]\n", "r.yaml"); }),
            "r.yaml: registration.max_iterations: must be a whole number");
  EXPECT_EQ(errorOf([] { registrationConfigFromYaml("min_label_pairs: -3\n", "r.yaml"); }),
            "r.yaml: registration.min_label_pairs: must be a whole number >= 0, got '-3'");
  EXPECT_EQ(errorOf([] { registrationConfigFromYaml("max_iterations: [\n", "r.yaml"); }).rfind("r.yaml: invalid YAML", 0), 0u);
  EXPECT_EQ(errorOf([] { configFromYaml<PropertyIcpConfig>("class_radius: {\"he\\x05at\": 1}\n", "p.yaml", "property_icp", {}); }),
            "p.yaml: property_icp.class_radius: must be printable UTF-8 text");
  // No suggestion when nothing is close.
  EXPECT_EQ(errorOf([] { registrationConfigFromYaml("zzzzzzzzzzzzzzzz: 1\n", "r.yaml"); }),
            "r.yaml: registration: unknown key 'zzzzzzzzzzzzzzzz'");

  const auto dir = test::scratchDir();
  std::ofstream(dir / "run.yaml") << "slam: {keyframe_distance: 2}\nloop_closure:\n  verification:\n"
                                     "    registration: {max_correspondence_distance: 0}\n";
  SlamConfig c;
  const std::string file = (dir / "run.yaml").string();
  EXPECT_EQ(errorOf([&] { c.applyYamlFile(file); }),
            file + ": loop_closure.verification.registration.max_correspondence_distance: must be > 0, got 0");
  std::ofstream(dir / "typo.yaml") << "odometri: {mode: map}\n";
  EXPECT_EQ(errorOf([&] { c.applyYamlFile(dir / "typo.yaml"); }),
            (dir / "typo.yaml").string() + ": unknown key 'odometri' (did you mean 'odometry'?)");
}

TEST(ConfigFields, SetOverridesAnyKey) {
  SlamConfig c = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  c.applySetting("odometry.registration.max_iterations=7");
  c.applySetting("slam.keyframe_distance=2.5");
  c.applySetting("property_icp.class_radius.heat=3");
  c.applySetting("loop_closure.candidates.constellation.min_inliers=3");
  c.applySetting("loop_closure.candidates.constellation.model=full-3d");
  EXPECT_EQ(c.odometry.registration.max_iterations, 7);
  EXPECT_DOUBLE_EQ(c.keyframe_distance, 2.5);
  EXPECT_DOUBLE_EQ(c.property_icp.class_radius.at("heat"), 3.0);
  EXPECT_EQ(c.loop_closure.candidates.constellation.model, ConstellationModel::Full3D);
  EXPECT_EQ(errorOf([&] { c.applySetting("odometry.registration.max_iterations=0"); }),
            "--set: odometry.registration.max_iterations: must be >= 1, got 0");
  EXPECT_EQ(errorOf([&] { c.applySetting("odometry.voxel_sise=1"); }),
            "--set: odometry: unknown key 'voxel_sise' (did you mean 'voxel_size'?)");
  EXPECT_EQ(errorOf([&] { c.applySetting("odometry.voxel_size"); }),
            "--set: expected KEY=VALUE, got 'odometry.voxel_size'");
}

// A retired experiment's key (src/core/retired_keys.cpp) is unknown like any other, and the error
// says where its write-up lives, however the key is spelled (run section, one command's section).
TEST(ConfigFields, RetiredKeysPointToTheirHistory) {
  SlamConfig c;
  EXPECT_EQ(errorOf([&] { c.applySetting("odometry.slip_guess_translation=0.15"); }),
            "--set: odometry: unknown key 'slip_guess_translation' (retired: measured and not adopted, see "
            "docs/history/odometry-sensor-frame-and-slip-guess.md)");
  EXPECT_EQ(errorOf([&] { c.applySetting("loop_closure.verification.probe_source_points=2000"); }),
            "--set: loop_closure.verification: unknown key 'probe_source_points' (retired: measured and not "
            "adopted, see docs/history/loop-verification-shortcuts.md)");
  EXPECT_EQ(errorOf([] { odometryConfigFromYaml("map_skips_fallback: true\n", "odo.yaml"); }),
            "odo.yaml: odometry: unknown key 'map_skips_fallback' (retired: measured and not adopted, see "
            "docs/history/odometry-map-skips.md)");
  OdometryConfig o;
  EXPECT_NE(errorOf([&] { applyConfigSetting(o, "map_skips_flagged=true"); }).find("docs/history/odometry-map-skips.md"),
            std::string::npos);
  // Internal thresholds that became constants name the file; keys that moved name their new path.
  EXPECT_EQ(errorOf([&] { c.applySetting("odometry.relocalise_min_gain=0.1"); }),
            "--set: odometry: unknown key 'relocalise_min_gain' (now a constant in src/odometry/odometry_checks.hpp; "
            "see docs/configuration.md)");
  EXPECT_EQ(errorOf([&] { c.applySetting("loop_closure.candidates.constellation.max_hypotheses=10"); }),
            "--set: loop_closure.candidates.constellation: unknown key 'max_hypotheses' (now a constant in "
            "src/loop/candidates.cpp; see docs/configuration.md)");
  EXPECT_EQ(errorOf([&] { c.applySetting("loop_closure.consistency.use_pairwise=false"); }),
            "--set: loop_closure.consistency: unknown key 'use_pairwise' (the switch of an adopted measure, now always "
            "on in src/loop/loop_detector.cpp; see docs/configuration.md)");
  EXPECT_EQ(errorOf([&] { c.applySetting("odometry.relocalise_suspect=true"); }),
            "--set: odometry: unknown key 'relocalise_suspect' (moved to odometry.recovery.relocalise_suspect)");
  EXPECT_EQ(errorOf([] { odometryConfigFromYaml("label_axis_range: 3\n", "odo.yaml"); }),
            "odo.yaml: odometry: unknown key 'label_axis_range' (moved to odometry.label_axis.range)");
  EXPECT_NE(errorOf([] { globalRegistrationConfigFromYaml("ambiguity_ratio: 0.8\n", "g.yaml"); })
                .find("now a constant in src/registration/global_registration.cpp"),
            std::string::npos);
  c.applySetting("odometry.recovery.relocalise_suspect=true");
  EXPECT_TRUE(c.odometry.recovery.relocalise_suspect);
  // A key that merely ends like a retired one is not taken for it.
  EXPECT_EQ(errorOf([&] { applyConfigSetting(o, "guess_yaw=1"); }).find("retired"), std::string::npos);
}

// One ICP is configured (issue 37): loop verification and the global registration's refinement
// run tracking's, with only their overrides stated; their defaults are what the full copies were.
TEST(ConfigFields, VerificationAndRefinementOverrideTrackingsIcp) {
  nlohmann::json verification = configToJson(RegistrationConfig{});
  verification["max_correspondence_distance"] = 1.5;
  verification["max_iterations"] = 60;
  verification["max_source_points"] = 6000;
  verification["coarse_source_points"] = 0;
  verification["index"] = "kdtree";
  EXPECT_EQ(configToJson(VerificationConfig{}.icp()), verification);
  nlohmann::json refinement = configToJson(RegistrationConfig{});
  refinement["max_iterations"] = 30;
  refinement["max_source_points"] = 1500;
  refinement["coarse_source_points"] = 0;
  EXPECT_EQ(configToJson(GlobalRegistrationConfig{}.refinementIcp()), refinement);

  // In a run both follow odometry.registration: the method's use_classes and any user setting.
  SlamConfig c = SlamConfig::forMethod(SlamMethod::IcpPgo);
  c.applySetting("odometry.registration.metric=point");
  c.applySetting("odometry.registration.robust_min_scale=0.02");
  c.applySetting("loop_closure.verification.registration.max_iterations=45");
  const RegistrationConfig loop = pipeline_detail::loopClosureConfigFor(c).verification.icp();
  EXPECT_FALSE(loop.use_classes);
  EXPECT_EQ(loop.metric, IcpMetric::PointToPoint);
  EXPECT_DOUBLE_EQ(loop.robust_min_scale, 0.02);
  EXPECT_EQ(loop.max_iterations, 45);
  EXPECT_DOUBLE_EQ(loop.max_correspondence_distance, 1.5);
  const RegistrationConfig refine = globalConfigOf(c.odometry).refinementIcp();
  EXPECT_EQ(refine.metric, IcpMetric::PointToPoint);
  EXPECT_DOUBLE_EQ(refine.robust_min_scale, 0.02);
  EXPECT_EQ(refine.max_iterations, 30);

  // The keys of the old copies name where they live now.
  EXPECT_EQ(errorOf([&] { c.applySetting("loop_closure.verification.registration.metric=point"); }),
            "--set: loop_closure.verification.registration: unknown key 'metric' (moved to "
            "odometry.registration.metric: loop verification runs tracking's ICP and states only its overrides)");
  EXPECT_EQ(errorOf([&] { c.applySetting("odometry.global_registration.refinement.robust_kernel=cauchy"); }),
            "--set: odometry.global_registration.refinement: unknown key 'robust_kernel' (moved to "
            "odometry.registration.robust_kernel: the refinement runs tracking's ICP and states only its overrides)");
  EXPECT_NE(errorOf([] { LoopClosureConfig::fromYamlString("verification: {registration: {metric: point}}\n", "l.yaml"); })
                .find("moved to odometry.registration.metric"),
            std::string::npos);
  // A typo of an override is a typo, not a moved key.
  EXPECT_EQ(errorOf([&] { c.applySetting("loop_closure.verification.registration.max_iteration=45"); }),
            "--set: loop_closure.verification.registration: unknown key 'max_iteration' (did you mean "
            "'max_iterations'?)");
  // `hazmap register --config` reads a plain registration section: a typo there is only a typo.
  EXPECT_EQ(errorOf([] { registrationConfigFromYaml("registration: {metrik: point}\n", "r.yaml"); }),
            "r.yaml: registration: unknown key 'metrik' (did you mean 'metric'?)");
}

TEST(PropertyIcpConfig, SetsTheClassTableOnce) {
  PropertyIcpConfig p;
  EXPECT_TRUE(p.empty());
  const ClassTable table = ClassTable::defaults();
  p.mismatch_penalty = 4.0;
  addClassRadius(p, "heat=5.5");
  addClassRadius(p, "2=0.5");  // by id
  const ClassTable t = p.applyTo(table);
  EXPECT_DOUBLE_EQ(t.mismatch_penalty, 4.0);
  EXPECT_DOUBLE_EQ(t.at(1).search_radius, 5.5);
  EXPECT_DOUBLE_EQ(t.at(2).search_radius, 0.5);
  EXPECT_DOUBLE_EQ(t.at(3).search_radius, table.at(3).search_radius);
  RegistrationConfig r;
  EXPECT_DOUBLE_EQ(r.effectiveMismatchPenalty(t), 4.0);
  r.use_classes = false;
  EXPECT_DOUBLE_EQ(r.effectiveMismatchPenalty(t), 0.0);
  addClassRadius(p, "lava=1");
  EXPECT_EQ(errorOf([&] { p.applyTo(table, "run.yaml"); }),
            "run.yaml: class_radius: unknown class 'lava' (the class table has none, heat, water, radiation)");
  EXPECT_EQ(errorOf([&] { addClassRadius(p, "heat"); }), "--class-radius: expected NAME=RADIUS (e.g. heat=3), got 'heat'");
  EXPECT_EQ(errorOf([&] { addClassRadius(p, "heat=-1"); }), "property_icp.class_radius.heat: must be >= 0, got -1");
}

TEST(ConfigCli, ReferencePageIsUpToDate) {
  const auto page = test::runCli("config --markdown");
  ASSERT_EQ(page.exit_code, 0) << page.output;
  EXPECT_EQ(page.output, readTextFile(test::sourceDir("docs/configuration.md")))
      << "regenerate: build/apps/hazmap config --markdown > docs/configuration.md";
  for (const char* key : {"`odometry.registration`", "`mismatch_penalty`", "`class_radius`", "`loop_closure.verification.registration`",
                          "`simulate.sensor`", "`keyframe_distance`"})
    EXPECT_NE(page.output.find(key), std::string::npos) << key;
}

TEST(ConfigCli, DumpDefaultsAndCheck) {
  const auto json = test::runCli("config --dump-defaults --json");
  ASSERT_EQ(json.exit_code, 0) << json.output;
  EXPECT_EQ(nlohmann::json::parse(json.output), configToJson(SlamConfig::forMethod(SlamMethod::PropertyIcpPgo)));
  const auto icp = test::runCli("config --dump-defaults --json --method icp");
  EXPECT_EQ(nlohmann::json::parse(icp.output)["loop_closure"]["method"], "distance");
  const auto yaml = test::runCli("config --dump-defaults");
  ASSERT_EQ(yaml.exit_code, 0);
  const auto dir = test::scratchDir();
  std::ofstream(dir / "defaults.yaml") << yaml.output;
  const auto ok = test::runCli("config --check '" + (dir / "defaults.yaml").string() + "'");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  std::ofstream(dir / "bad.yaml") << "graph: {loop_loss_scale: -2}\n";
  const auto bad = test::runCli("config --check '" + (dir / "bad.yaml").string() + "'");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.output.find("bad.yaml: graph.loop_loss_scale: must be > 0, got -2"), std::string::npos) << bad.output;
  const auto sim = test::runCli("config --dump-defaults --for simulate");
  EXPECT_EQ(sim.output, sim::SimulatorConfig{}.toYamlString());
}

TEST(ConfigCli, ParameterFlagsReachTheRun) {
  // --class-radius with an unknown class and --set with a bad key fail before any work,
  // naming the flag and the key.
  const auto dir = test::scratchDir();
  const auto r1 = test::runCli("register a.pcd b.pcd --class-radius lava=2");
  EXPECT_NE(r1.exit_code, 0);
  EXPECT_NE(r1.output.find("unknown class 'lava'"), std::string::npos) << r1.output;
  const auto r2 = test::runCli("register a.pcd b.pcd --set max_iteration=2");
  EXPECT_NE(r2.exit_code, 0);
  EXPECT_NE(r2.output.find("--set: unknown key 'max_iteration' (did you mean 'max_iterations'?)"), std::string::npos)
      << r2.output;
}
