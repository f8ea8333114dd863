// `hazmap view`: the self-contained HTML page (what it embeds, bad input) and the page itself in
// a real browser (Debian's headless Chromium with SwiftShader WebGL), driven through a copy of
// the page with a test script appended; the script writes its findings into the DOM, which
// Chromium's --dump-dom prints.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <stb/stb_image.h>

#include <cmath>
#include <fstream>
#include <regex>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/ply.hpp"
#include "hazmap/map/global_map.hpp"
#include "hazmap/map/hazards.hpp"
#include "hazmap/map/viewer.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

constexpr ClassId kNone = 0, kHeat = 1, kWater = 2;

void addPatch(LabeledCloud& c, float x0, float y0, float w, float h, float z, ClassId cls, float value = 0) {
  for (float x = x0; x < x0 + w - 1e-4f; x += 0.1f)
    for (float y = y0; y < y0 + h - 1e-4f; y += 0.1f) c.push_back({x + 0.05f, y + 0.05f, z}, cls, 0, 0, value);
}

// A 12 × 8 m floor with a heat patch, a puddle and two lone marker points above the floor (the
// distance tool's known points).
struct Scene {
  ViewerScene scene;
  Eigen::Vector3d a, b;
};
Scene testScene() {
  LabeledCloud scan;
  scan.enableProperty();
  addPatch(scan, 0, 0, 12, 8, 0.0f, kNone);
  addPatch(scan, 2, 2, 1.5f, 1.0f, 0.15f, kHeat, 60.0f);
  addPatch(scan, 7, 5, 2.0f, 1.5f, 0.15f, kWater, 1.0f);
  scan.push_back({1.234f, 6.55f, 1.0f}, kNone);
  scan.push_back({10.55f, 1.25f, 0.45f}, kNone);
  GlobalMapConfig cfg;
  cfg.voxel_size = 0.1;
  GlobalMap map(cfg);
  map.insert(0, scan, Eigen::Isometry3d::Identity());
  Scene s;
  s.scene.title = "viewer test";
  s.scene.map = map.cloud();
  s.scene.hazards = findHazards(map);
  for (std::size_t i = 0; i < s.scene.map.size(); ++i) {
    const Eigen::Vector3d p = s.scene.map.points[i].cast<double>();
    if (p.z() > 0.9) s.a = p;
    else if (p.z() > 0.4) s.b = p;
  }
  ViewerTrajectory t{"estimate", {}, {208, 64, 255}};
  for (int i = 0; i <= 20; ++i) t.positions.emplace_back(0.5 + 0.5 * i, 4.0, 0.5);
  s.scene.trajectories.push_back(t);
  return s;
}

std::string chromiumPath() {
  for (const char* p : {"/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome"})
    if (std::filesystem::exists(p)) return p;
  return {};
}

// Chromium flags for this machine: SwiftShader WebGL, no sandbox (root), nothing phoned home,
// and every host name unresolvable so that any fetch the page tried would fail loudly.
std::string chromium(const std::filesystem::path& dir, const std::string& mode, const std::filesystem::path& page) {
  // TMPDIR: a Chromium killed by the timeout leaves its singleton socket folder there; one short
  // folder for the whole test binary, removed when it exits.
  static const test::ShortTempDir tmp;
  return "timeout 90 env TMPDIR=" + tmp.path().string() + " " + chromiumPath() +
         " --headless=new --use-angle=swiftshader --enable-unsafe-swiftshader --no-sandbox --no-first-run"
         " --disable-background-networking --disable-component-update --disable-sync --disable-gpu-sandbox"
         " --host-resolver-rules='MAP * ~NOTFOUND' --window-size=1400,900 --virtual-time-budget=8000"
         " --user-data-dir=" + (dir / "chromium-profile").string() + " " + mode + " file://" +
         std::filesystem::absolute(page).string() + " 2>" + (dir / "chromium.log").string();
}

std::string runCommand(const std::string& cmd) {
  std::string out;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return out;
  char buf[65536];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) out.append(buf, n);
  pclose(pipe);
  return out;
}

// The page with an error recorder first in <head> and `driver` (a JS async function body that
// fills `out`) after everything else.
std::filesystem::path hookedPage(const std::filesystem::path& page, const std::filesystem::path& dir,
                                 const std::string& driver) {
  std::string html = readTextFile(page);
  const std::string recorder =
      "<script>window.__errors=[];addEventListener('error',e=>__errors.push('error: '+e.message));"
      "const __ce=console.error;console.error=function(){__errors.push('console.error: '+"
      "Array.from(arguments).join(' '));__ce.apply(console,arguments)};</script>";
  const std::string script =
      "<script>(async function(){const out={};try{" + driver +
      "}catch(e){out.exception=String(e&&e.stack||e)}out.errors=window.__errors;"
      "out.resources=performance.getEntriesByType('resource').map(r=>r.name);"
      "const pre=document.createElement('pre');pre.id='hazmap-test-result';"
      "pre.textContent=JSON.stringify(out);document.body.appendChild(pre);})();</script>";
  const auto head = html.find("<head>");
  const auto body = html.rfind("</body>");
  EXPECT_NE(head, std::string::npos);
  EXPECT_NE(body, std::string::npos);
  html.insert(body, script);
  html.insert(head + 6, recorder);
  const auto hooked = dir / "hooked.html";
  writeTextAtomically(hooked, html);
  return hooked;
}

nlohmann::json runInBrowser(const std::filesystem::path& page, const std::filesystem::path& dir,
                            const std::string& driver) {
  const std::string dom = runCommand(chromium(dir, "--dump-dom", hookedPage(page, dir, driver)));
  const std::regex result("<pre id=\"hazmap-test-result\">([^<]*)</pre>");
  std::smatch m;
  if (!std::regex_search(dom, m, result)) {
    ADD_FAILURE() << "no test result in the page; chromium log:\n" << readTextFile(dir / "chromium.log").substr(0, 3000);
    return {};
  }
  std::string text = m[1].str();
  for (const auto& [entity, c] : std::vector<std::pair<std::string, std::string>>{{"&quot;", "\""}, {"&lt;", "<"}, {"&gt;", ">"}, {"&amp;", "&"}})
    for (std::size_t at = 0; (at = text.find(entity, at)) != std::string::npos; at += c.size()) text.replace(at, entity.size(), c);
  return nlohmann::json::parse(text);
}

void expectOffline(const nlohmann::json& r) {
  EXPECT_TRUE(r["errors"].empty()) << r["errors"].dump();
  for (const auto& name : r["resources"]) {
    const std::string url = name.get<std::string>();
    EXPECT_FALSE(url.starts_with("http:") || url.starts_with("https:")) << "the page fetched " << url;
  }
}

// ---- the page, without a browser ---------------------------------------------------------------

TEST(ViewerPage, EmbedsThreeAndTheQuantisedMapAndLinksNothing) {
  const Scene s = testScene();
  const auto dir = test::scratchDir();
  const ViewerReport r = writeViewer(dir / "viewer.html", s.scene);
  EXPECT_EQ(r.points_total, s.scene.map.size());
  EXPECT_EQ(r.points_embedded, s.scene.map.size());
  const std::string html = readTextFile(dir / "viewer.html");
  EXPECT_EQ(r.bytes, html.size());
  EXPECT_NE(html.find("REVISION=\"111\""), std::string::npos);  // Debian's three.js, inline
  EXPECT_NE(html.find("OrbitControls"), std::string::npos);
  // Nothing is loaded from elsewhere: no src/href attributes, no stylesheet links, no CSS
  // url(), and (outside three.js's own loaders, which the page never calls) no fetches.
  for (const char* pattern : {" src=", " href=", "<link", "url(", "@import"})
    EXPECT_EQ(html.find(pattern), std::string::npos) << pattern;
  std::string own = html;
  for (const char* lib : {"/usr/share/javascript/three/three.min.js",
                          "/usr/share/javascript/three/examples/js/controls/OrbitControls.js"}) {
    const std::string text = readTextFile(lib);
    const auto at = own.find(text);
    ASSERT_NE(at, std::string::npos) << lib << " is not embedded verbatim";
    own.erase(at, text.size());
  }
  for (const char* pattern : {"fetch(", "XMLHttpRequest", "import(", "http://", "https://", "WebSocket"})
    EXPECT_EQ(own.find(pattern), std::string::npos) << pattern;
  // The metadata round-trips and the dequantised positions are within half a step.
  const auto begin = html.find("<script type=\"application/json\" id=\"hazmap-meta\">");
  ASSERT_NE(begin, std::string::npos);
  const auto start = html.find('>', begin) + 1;
  const nlohmann::json meta = nlohmann::json::parse(html.substr(start, html.find("</script>", start) - start));
  EXPECT_EQ(meta["hazards"].size(), s.scene.hazards.size());
  EXPECT_EQ(meta["points_embedded"].get<std::size_t>(), s.scene.map.size());
  std::size_t grouped = 0;
  for (const auto& g : meta["groups"]) grouped += g["count"].get<std::size_t>();
  EXPECT_EQ(grouped, s.scene.map.size());
  EXPECT_LT(meta["qstep"][0].get<double>(), 0.001);  // 12 m / 65535
}

// A run's (or a merge's) folder with changes.json: `hazmap view` carries the changes into the page.
TEST(ViewerPage, AFolderWithChangesShowsThem) {
  const auto dir = test::scratchDir();
  const Scene s = testScene();
  writePly(dir / "map.ply", s.scene.map);
  writeHazardsJson(dir / "hazards.json", s.scene.hazards, 0.1);
  HazardChange gone;
  gone.kinds = {"gone"}, gone.class_name = "heat", gone.before = Eigen::Vector3d(2.0, 6.0, 0.15);
  writeHazardChanges(dir, {gone});
  const ViewerScene scene = loadRunScene(dir);
  ASSERT_EQ(scene.changes.size(), 1u);
  EXPECT_EQ(scene.changes[0].kinds, std::vector<std::string>{"gone"});
  EXPECT_NE(viewerHtml(scene).find("\"changes\":[{"), std::string::npos);
}

TEST(ViewerPage, TooLargeOrMissingFilesFailInOneLineAndWriteNothing) {
  const Scene s = testScene();
  const auto dir = test::scratchDir();
  ViewerConfig small;
  small.max_bytes = 1'000'000;  // three.js alone is ~0.9 MB
  try {
    writeViewer(dir / "viewer.html", s.scene, small);
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("--max-points"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos);
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "viewer.html"));
  // With decimation allowed (what `hazmap run` does) it fits, fewer points, evenly chosen.
  const ViewerReport full = writeViewer(dir / "full.html", s.scene);
  small.max_bytes = full.bytes - 50'000;
  small.decimate_to_fit = true;
  const ViewerReport r = writeViewer(dir / "viewer.html", s.scene, small);
  EXPECT_LT(r.points_embedded, r.points_total);
  EXPECT_LE(r.bytes, small.max_bytes);
  // The CLI on a folder without map.ply / hazards.json, and on a map over --max-mb.
  std::filesystem::create_directories(dir / "empty");
  auto cli = test::runCli("view " + (dir / "empty").string());
  EXPECT_NE(cli.exit_code, 0);
  EXPECT_NE(cli.output.find("map.ply"), std::string::npos) << cli.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "empty" / "viewer.html"));
  std::filesystem::create_directories(dir / "run");
  writeMapPly(dir / "run" / "map.ply", s.scene.map, s.scene.classes);
  cli = test::runCli("view " + (dir / "run").string());
  EXPECT_NE(cli.exit_code, 0);
  EXPECT_NE(cli.output.find("hazards.json"), std::string::npos) << cli.output;
  writeTextAtomically(dir / "run" / "hazards.json", R"({"hazards": [{"id": 1e300, "class": "heat"}]})");
  cli = test::runCli("view " + (dir / "run").string());
  EXPECT_NE(cli.exit_code, 0);
  EXPECT_NE(cli.output.find("hazards.json: not a hazards.json: id is not a count"), std::string::npos) << cli.output;
  writeHazardsJson(dir / "run" / "hazards.json", s.scene.hazards, 0.1);
  EXPECT_EQ(readHazardsJson(dir / "run" / "hazards.json").size(), s.scene.hazards.size());
  cli = test::runCli("view " + (dir / "run").string() + " --max-mb 0.95");
  EXPECT_NE(cli.exit_code, 0);
  EXPECT_NE(cli.output.find("--max-points"), std::string::npos) << cli.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "run" / "viewer.html"));
  cli = test::runCli("view " + (dir / "run").string() + " --out " + (dir / "page.html").string());
  EXPECT_EQ(cli.exit_code, 0) << cli.output;
  EXPECT_TRUE(std::filesystem::exists(dir / "page.html"));
}

// ---- the page in headless Chromium -------------------------------------------------------------

class ViewerBrowser : public ::testing::Test {
 protected:
  void SetUp() override {
    // scripts/install-deps.sh installs Debian's chromium; without it this test cannot judge.
    ASSERT_FALSE(chromiumPath().empty()) << "chromium is missing: run scripts/install-deps.sh";
  }
};

TEST_F(ViewerBrowser, ShowsTheMapHazardTableFlightsAndMeasuresDistances) {
  const Scene s = testScene();
  const auto dir = test::scratchDir();
  writeViewer(dir / "viewer.html", s.scene);
  const auto js = [](const Eigen::Vector3d& p) { return fmt::format("{},{},{}", p.x(), p.y(), p.z()); };
  const std::string driver =
      "const v=window.hazmapViewer;out.ready=!!(v&&v.ready);out.rows=v.hazardRows().length;"
      "v.setView('top');out.red=v.countPixels([230,25,25],30);out.blue=v.countPixels([25,90,235],30);"
      "const bg=v.countPixels([27,30,35],6);const gl=document.getElementById('canvas');"
      "out.drawn=gl.width*gl.height-bg;"
      "out.before=v.camera();v.clickRow(1);await new Promise(r=>setTimeout(r,2000));out.after=v.camera();"
      "out.flying=v.flying;"
      "v.setView('top');v.lookAt(6,4,0,14);v.setMeasuring(true);"
      "out.pickA=v.clickWorld(" + js(s.a) + ");out.pickB=v.clickWorld(" + js(s.b) + ");"
      "out.distance=v.lastDistance;out.picked=v.picked;";
  const nlohmann::json r = runInBrowser(dir / "viewer.html", dir, driver);
  ASSERT_FALSE(r.is_null());
  EXPECT_FALSE(r.contains("exception")) << r["exception"];
  EXPECT_TRUE(r["ready"].get<bool>());
  expectOffline(r);
  ASSERT_EQ(s.scene.hazards.size(), 2u);
  EXPECT_EQ(r["rows"].get<std::size_t>(), s.scene.hazards.size());
  EXPECT_GT(r["drawn"].get<int>(), 10000);  // not blank
  EXPECT_GT(r["red"].get<int>(), 100);      // the heat patch
  EXPECT_GT(r["blue"].get<int>(), 100);     // the puddle
  // The row of hazard #2 (the puddle) moved the orbit centre onto it.
  const auto target = r["after"]["target"];
  EXPECT_NEAR(target[0].get<double>(), s.scene.hazards[1].centroid.x(), 0.01);
  EXPECT_NEAR(target[1].get<double>(), s.scene.hazards[1].centroid.y(), 0.01);
  EXPECT_GT(std::hypot(r["after"]["position"][0].get<double>() - r["before"]["position"][0].get<double>(),
                       r["after"]["position"][1].get<double>() - r["before"]["position"][1].get<double>()), 1.0);
  EXPECT_FALSE(r["flying"].get<bool>());
  // Two clicks on the known points: their distance to 1 cm.
  ASSERT_TRUE(r["distance"].is_number()) << r.dump();
  EXPECT_NEAR(r["distance"].get<double>(), (s.a - s.b).norm(), 0.01);
  EXPECT_NEAR(r["picked"]["world"][2].get<double>(), s.b.z(), 0.01);
  EXPECT_EQ(r["picked"]["class"].get<std::string>(), "none");
}

// The changes since the prior mission (changes.json of a run with --prior or a merge): a table
// (changed first), a ring per change with an arrow for a move, a layer that hides them, rows that
// fly to them. A page without changes carries none.
TEST_F(ViewerBrowser, ShowsTheChangesSinceThePriorMission) {
  Scene s = testScene();
  const auto dir = test::scratchDir();
  EXPECT_EQ(viewerHtml(s.scene).find("\"changes\":"), std::string::npos);
  HazardChange unchanged, gone, moved;
  unchanged.kinds = {"unchanged"}, unchanged.class_name = "water";
  unchanged.before = unchanged.after = Eigen::Vector3d(8.0, 5.75, 0.15);
  gone.kinds = {"gone"}, gone.class_name = "heat", gone.before = Eigen::Vector3d(2.0, 6.0, 0.15), gone.confidence = 1;
  moved.kinds = {"moved"}, moved.class_name = "heat", moved.mission = 2, moved.confidence = 0.8;
  moved.before = Eigen::Vector3d(2.75, 2.5, 0.15), moved.after = Eigen::Vector3d(9.5, 2.0, 0.15), moved.moved_m = 6.77;
  s.scene.changes = {unchanged, gone, moved};
  writeViewer(dir / "viewer.html", s.scene);
  const std::string driver =
      "const v=window.hazmapViewer;out.rows=v.changeRows();v.setView('top');v.lookAt(6,4,0,14);"
      "out.orange=v.countPixels([255,160,30],30);out.red=v.countPixels([255,60,60],30);"
      "v.setChangesVisible(false);out.orange_off=v.countPixels([255,160,30],30);v.setChangesVisible(true);"
      "v.clickChange(1,true);out.target=v.camera().target;";
  const nlohmann::json r = runInBrowser(dir / "viewer.html", dir, driver);
  ASSERT_FALSE(r.is_null());
  EXPECT_FALSE(r.contains("exception")) << r["exception"];
  expectOffline(r);
  ASSERT_EQ(r["rows"].size(), 3u) << r.dump();
  // Changed first (in their order), the unchanged puddle last.
  EXPECT_EQ(r["rows"][0][0], "gone");
  EXPECT_EQ(r["rows"][1][0], "moved");
  EXPECT_NE(r["rows"][1][3].get<std::string>().find("mission 2; 6.77 m from 2.8, 2.5"), std::string::npos) << r["rows"][1];
  EXPECT_EQ(r["rows"][2][0], "unchanged");
  EXPECT_GT(r["orange"].get<int>(), 50);  // the moved source's ring and arrow
  EXPECT_GT(r["red"].get<int>(), 50);     // the gone one's ring (beside the heat patch's red points)
  EXPECT_LT(r["orange_off"].get<int>(), r["orange"].get<int>() / 4);
  EXPECT_NEAR(r["target"][0].get<double>(), 9.5, 0.01);
  EXPECT_NEAR(r["target"][1].get<double>(), 2.0, 0.01);
}

}  // namespace
}  // namespace hazmap

namespace hazmap {
namespace {

struct Screenshot {
  int w = 0, h = 0;
  std::vector<std::uint8_t> rgb;
};
Screenshot readScreenshot(const std::filesystem::path& path) {
  Screenshot s;
  int n = 0;
  unsigned char* data = stbi_load(path.string().c_str(), &s.w, &s.h, &n, 3);
  if (!data) return s;
  s.rgb.assign(data, data + std::size_t(s.w) * std::size_t(s.h) * 3);
  stbi_image_free(data);
  return s;
}

// A small simulated run of the paper's facility through the CLI: `hazmap run` writes
// viewer.html by default; the page shows red and blue map points, one table row per hazard of
// hazards.json, and a row click flies to that hazard.
TEST_F(ViewerBrowser, RunWritesAViewerThatShowsItsHazards) {
  const auto dir = test::scratchDir();
  ASSERT_EQ(test::runCli("simulate --scenario naraha --frames 30 --out " + (dir / "seq").string()).exit_code, 0);
  const auto run = test::runCli("run " + (dir / "seq").string() + " --method icp --out " + (dir / "run").string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("viewer.html"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("Map error"), std::string::npos) << run.output;
  const auto page = dir / "run" / "viewer.html";
  ASSERT_TRUE(std::filesystem::exists(page));
  EXPECT_LT(std::filesystem::file_size(page), std::size_t(30) << 20);
  const std::vector<Hazard> hazards = readHazardsJson(dir / "run" / "hazards.json");
  ASSERT_GE(hazards.size(), 2u);

  // What a person sees: a screenshot of the page as it opens.
  runCommand(chromium(dir, "--screenshot=" + (dir / "shot.png").string(), page));
  const Screenshot shot = readScreenshot(dir / "shot.png");
  ASSERT_EQ(shot.w, 1400) << readTextFile(dir / "chromium.log").substr(0, 2000);
  std::size_t red = 0, blue = 0, grey = 0;
  const int view_w = shot.w - 440;  // left of the side panel
  for (int y = 0; y < shot.h; ++y)
    for (int x = 0; x < view_w; ++x) {
      const std::uint8_t* p = &shot.rgb[(std::size_t(y) * std::size_t(shot.w) + std::size_t(x)) * 3];
      red += p[0] > 180 && p[1] < 70 && p[2] < 70;
      blue += p[2] > 180 && p[0] < 80 && p[1] < 140;
      grey += p[0] > 100 && std::abs(p[0] - p[1]) < 6 && std::abs(p[1] - p[2]) < 6;
    }
  EXPECT_GT(grey, 20000u);  // the canvas is not blank
  EXPECT_GT(red, 30u);
  EXPECT_GT(blue, 30u);

  // The page's own state.
  const nlohmann::json r = runInBrowser(page, dir,
      "const v=window.hazmapViewer;out.rows=v.hazardRows();out.before=v.camera();v.clickRow(0);"
      "await new Promise(r=>setTimeout(r,2000));out.after=v.camera();out.truth=v.meta.trajectories.length;");
  ASSERT_FALSE(r.is_null());
  EXPECT_FALSE(r.contains("exception")) << r["exception"];
  expectOffline(r);
  ASSERT_EQ(r["rows"].size(), hazards.size());
  EXPECT_EQ(r["rows"][0][1].get<std::string>(), hazards[0].class_name);
  EXPECT_EQ(r["truth"].get<int>(), 2);  // estimate and ground truth (the sequence has poses.txt)
  EXPECT_NEAR(r["after"]["target"][0].get<double>(), hazards[0].centroid.x(), 0.01);
  EXPECT_NEAR(r["after"]["target"][1].get<double>(), hazards[0].centroid.y(), 0.01);
  EXPECT_NE(r["after"]["position"], r["before"]["position"]);
}

}  // namespace
}  // namespace hazmap
