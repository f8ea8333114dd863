// Live property cameras (issue 33, part 2): frames through GStreamer pipelines ending in appsink,
// kept in a ring and used to label live scans with the same projection and rules as `hazmap
// label`. The real camera frame of ../shared/data/cameras (README there) through multifilesrc →
// pngdec → appsink labels its real LiDAR frame exactly as `hazmap label` does from the same image;
// 16-bit grey keeps every count over RTP (rtpgstpay); a frame on its way is waited for, a stalled
// camera is not, and is counted; bad pipelines and unsupported formats are one-line errors or counted rejections.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <stb/stb_image.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/properties/label_sequence.hpp"
#include "hazmap/properties/live_camera.hpp"
#include "hazmap/properties/live_labels.hpp"
#include "hazmap/sources/gst_camera.hpp"
#include "live_test_helpers.hpp"
#include "real_camera_frame.hpp"
#include "test_helpers.hpp"

namespace hazmap::test {
namespace {

namespace fs = std::filesystem;


/// The real frame's camera as a camera.yaml: plumb-bob lens and extrinsic from the data's JSON,
/// channel `temperature` read 1:1 from 8-bit grey (so the built-in heat rule, >= 60, splits the
/// image into bright and dark), its image folder beside it.
CameraCalibration realCamera(int width, int height) {
  const RealCameraCalibration real = readRealCameraCalibration(width, height);
  CameraCalibration c;
  c.name = "center_camera";
  c.model = CameraModel(real.intrinsics, "center_camera");
  c.T_camera_lidar = real.T_camera_lidar;
  c.channel.name = "temperature";
  c.channel.units = "grey";
  c.channel.scale = 1.0;
  c.channel.offset = 0.0;
  return c;
}

/// The real frame's image as grey counts 0..255 (Rec. 601 luminance, rounded): a folder of
/// `hazmap label` takes grey images only.
Gray16 realGrey() {
  int w = 0, h = 0, comp = 0;
  stbi_uc* rgb = stbi_load((sharedData("cameras/pjlab-center-camera") / "0.png").c_str(), &w, &h, &comp, 3);
  if (!rgb) throw std::runtime_error("cannot read 0.png");
  Gray16 g{w, h, std::vector<std::uint16_t>(static_cast<std::size_t>(w) * h)};
  for (std::size_t i = 0; i < g.pixels.size(); ++i)
    g.pixels[i] = static_cast<std::uint16_t>(std::lround(0.299 * rgb[3 * i] + 0.587 * rgb[3 * i + 1] + 0.114 * rgb[3 * i + 2]));
  stbi_image_free(rgb);
  return g;
}

TEST(LiveCameraRealFrame, GstreamerFrameLabelsTheScanAsHazmapLabelDoes) {
  const fs::path dir = scratchDir();
  const LabeledCloud cloud = readPcd(sharedData("cameras/pjlab-center-camera") / "0.pcd");
  const Gray16 grey = realGrey();
  CameraCalibration cam = realCamera(grey.width, grey.height);
  // `hazmap label` input: a one-scan sequence, the camera folder (camera.yaml, 000000.png, times.txt).
  {
    SequenceWriter writer(dir / "seq", ClassTable::defaults());
    writer.addFrame(cloud);
    writer.finish();
    writeTextAtomically(dir / "seq" / "times.txt", "0\n");
  }
  fs::create_directories(dir / "cam");
  writePng16(dir / "cam" / "000000.png", grey);  // the counts 0..255, as a grey camera gives
  writeTextAtomically(dir / "cam" / "times.txt", "0\n");
  writeTextAtomically(dir / "cam" / "camera.yaml", cameraYaml(cam));
  LabelOptions options;
  options.cameras = {dir / "cam" / "camera.yaml"};
  labelSequence(dir / "seq", dir / "labelled", options);
  const LabeledCloud offline = Sequence::open(dir / "labelled").frame(0);

  // Live: the same PNG through GStreamer into the ring, the scan labelled at the frame's time.
  const CameraCalibration read = readCameraYaml(dir / "cam" / "camera.yaml");
  auto camera = std::make_shared<LiveCamera>(read);
  GstFrameReceiver receiver("multifilesrc location=" + (dir / "cam" / "000000.png").string() +
                                " loop=false ! pngdec ! videoconvert ! video/x-raw,format=GRAY16_LE ! appsink sync=false",
                            "test pipeline", [&](CameraFrame&& f) { camera->push(f); });
  ASSERT_TRUE(waitUntil([&] { return camera->stats().frames >= 1; })) << receiver.stats().last_error;
  EXPECT_EQ(camera->stats().rejected, 0u) << camera->stats().last_error;
  const double t = camera->snapshot()->stamps().front();
  LiveLabeler labeler({camera}, PropertyRules::defaults({"temperature"}, ClassTable::defaults()), LabelerConfig{});
  LabeledCloud live = cloud;
  PropertyLabeler::apply(labeler.label(cloud, t), live);

  ASSERT_EQ(live.size(), offline.size());
  std::size_t hot = 0, cool = 0, differ = 0;
  for (std::size_t i = 0; i < live.size(); ++i) {
    const bool a = std::isnan(live.property[i]), b = std::isnan(offline.property[i]);
    differ += live.classes[i] != offline.classes[i] || a != b || (!a && live.property[i] != offline.property[i]);
    hot += !a && live.classes[i] != 0;
    cool += !a && live.classes[i] == 0;
  }
  EXPECT_EQ(differ, 0u);
  EXPECT_GT(hot + cool, 5000u);  // the camera sees a good part of the scan
  EXPECT_GT(hot, 1000u);         // bright surfaces: the rule gives the class …
  EXPECT_GT(cool, 300u);         // … and dark ones (768 of them) do not
}

TEST(LiveCameraRtp, Gray16KeepsEveryCountOverRtp) {
  const std::uint16_t port = freePortPair();
  std::mutex m;
  std::vector<CameraFrame> got;
  GstFrameReceiver receiver(GstFrameSender::receiverPipeline(port), "rtp receiver", [&](CameraFrame&& f) {
    std::lock_guard<std::mutex> lock(m);
    got.push_back(std::move(f));
  });
  const int w = 160, h = 120;  // 38 kB: many RTP packets per frame
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(w) * h * 2);
  for (std::size_t k = 0; k < bytes.size() / 2; ++k) {
    const auto v = static_cast<std::uint16_t>((k * 40503u) & 0xFFFF);  // every high and low byte
    bytes[2 * k] = static_cast<std::uint8_t>(v & 0xFF);
    bytes[2 * k + 1] = static_cast<std::uint8_t>(v >> 8);
  }
  {
    GstFrameSender sender("127.0.0.1", port, "rtp sender");
    // The receiver may still be starting: send until one arrives (each frame carries its caps).
    for (int i = 0; i < 50; ++i) {
      sender.send(w, h, "GRAY16_LE", bytes, std::int64_t(i) * 100'000'000);
      if (waitUntil([&] { std::lock_guard<std::mutex> lock(m); return !got.empty(); }, 0.2)) break;
    }
  }
  std::lock_guard<std::mutex> lock(m);
  ASSERT_FALSE(got.empty());
  const CameraFrame& f = got.front();
  EXPECT_EQ(f.encoding, "mono16");
  EXPECT_FALSE(f.big_endian);
  EXPECT_EQ(f.width, w);
  EXPECT_EQ(f.height, h);
  EXPECT_EQ(f.data, bytes);
  // Its stamp is the arrival on this machine's CLOCK_REALTIME (within a minute of now).
  timespec now;
  ::clock_gettime(CLOCK_REALTIME, &now);
  EXPECT_LT(std::abs(double(now.tv_sec) - double(f.time_ns) * 1e-9), 60.0);
  // Into a camera's values: raw · scale + offset, as a 16-bit PNG of the same counts gives.
  const CameraCalibration cam = smallCamera("rtp", w, h);
  LiveCamera camera(cam);
  ASSERT_TRUE(camera.push(f));
  Gray16 raw{w, h, {}};
  for (std::size_t p = 0; p < bytes.size() / 2; ++p) raw.pixels.push_back(std::uint16_t(bytes[2 * p] | bytes[2 * p + 1] << 8));
  const PropertyImage expected = toPropertyImage(raw, cam.channel, 0.0);
  EXPECT_EQ(camera.snapshot()->load(0, cam).values, expected.values);
}

TEST(LiveCameraErrors, BadPipelinesAreOneLineErrors) {
  const auto message = [](const std::string& pipeline) -> std::string {
    try {
      GstFrameReceiver r(pipeline, "--camera-pipeline", [](CameraFrame&&) {});
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  for (const std::string& p : {"nosuchelement ! appsink", "videotestsrc ! fakesink", "videotestsrc ! ! appsink",
                               "filesrc location=/nonexistent/file.png ! pngdec ! appsink"}) {
    const std::string m = message(p);
    EXPECT_FALSE(m.empty()) << p;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    EXPECT_NE(m.find("--camera-pipeline"), std::string::npos) << m;
  }
  EXPECT_NE(message("videotestsrc ! fakesink").find("no appsink"), std::string::npos);
  EXPECT_NE(message("nosuchelement ! appsink").find("does not parse"), std::string::npos);
}

TEST(LiveCameraErrors, UnsupportedFormatIsCountedNotFatal) {
  std::atomic<int> frames{0};
  GstFrameReceiver r("videotestsrc is-live=true ! video/x-raw,format=I420,width=64,height=48,framerate=30/1 ! appsink",
                     "test", [&](CameraFrame&&) { ++frames; });
  ASSERT_TRUE(waitUntil([&] { return r.stats().rejected >= 1; }));
  EXPECT_EQ(frames.load(), 0);
  EXPECT_NE(r.stats().last_error.find("I420"), std::string::npos) << r.stats().last_error;
  // A frame of another size than the calibration's: rejected by the camera, counted.
  const CameraCalibration cam = smallCamera("small");
  LiveCamera camera(cam);
  CameraFrame f{0, 32, 24, "mono8", false, 32, std::vector<std::uint8_t>(32 * 24)};
  EXPECT_FALSE(camera.push(f));
  EXPECT_EQ(camera.stats().rejected, 1u);
  EXPECT_NE(camera.stats().last_error.find("small"), std::string::npos);
}

TEST(LiveCameraLabeler, StalledCameraIsCountedAndItsNextFrameUsed) {
  const CameraCalibration cam = smallCamera("stalled");
  LiveCameraConfig config;
  config.wait = 0.2;
  auto camera = std::make_shared<LiveCamera>(cam, config);
  LiveLabeler labeler({camera}, PropertyRules::defaults({"temperature"}, ClassTable::defaults()), LabelerConfig{}, config);
  LabeledCloud scan;
  for (int i = 0; i < 100; ++i) scan.push_back(Eigen::Vector3f(0.01f * i, 0.0f, 5.0f));
  timespec now;
  ::clock_gettime(CLOCK_REALTIME, &now);
  const double t = double(now.tv_sec) + double(now.tv_nsec) * 1e-9;
  const ScanLabels labels = labeler.label(scan, t);  // never heard: not waited for, labelled without
  EXPECT_EQ(labels.image_index.at(0), -1);
  for (ClassId c : labels.classes) EXPECT_EQ(c, 0);
  EXPECT_EQ(camera->stats().scans_without_image, 1u);
  EXPECT_TRUE(camera->stats().stalled);
  // A frame arrives at the scan's time: the next scan uses it.
  CameraFrame f{static_cast<std::int64_t>(t * 1e9), 64, 48, "mono16", false, 128, std::vector<std::uint8_t>(64 * 48 * 2, 0x90)};
  ASSERT_TRUE(camera->push(f));
  const ScanLabels second = labeler.label(scan, t + 0.01);
  EXPECT_EQ(second.image_index.at(0), 0);
  EXPECT_FALSE(camera->stats().stalled);
  std::size_t heat = 0;
  for (ClassId c : second.classes) heat += c != 0;
  EXPECT_GT(heat, 50u);  // 0x9090 centikelvin = 97 °C on the points in view
}

TEST(LiveCameraLabeler, AFrameOnItsWayIsWaitedFor) {
  // The camera is alive (a frame 50 ms before the scan); the frame at the scan's own time comes
  // 150 ms after the scan is handed over: the scan waits and uses it, not the older one.
  const CameraCalibration cam = smallCamera("late");
  auto camera = std::make_shared<LiveCamera>(cam);
  LiveLabeler labeler({camera}, PropertyRules::defaults({"temperature"}, ClassTable::defaults()), LabelerConfig{});
  timespec now;
  ::clock_gettime(CLOCK_REALTIME, &now);
  const std::int64_t t_ns = std::int64_t{now.tv_sec} * 1'000'000'000 + now.tv_nsec;
  const auto frame = [](std::int64_t ns, std::uint8_t high) {
    return CameraFrame{ns, 64, 48, "mono16", false, 128, std::vector<std::uint8_t>(64 * 48 * 2, high)};
  };
  ASSERT_TRUE(camera->push(frame(t_ns - 50'000'000, 0x70)));  // 15 °C
  std::thread late([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    camera->push(frame(t_ns, 0x90));  // 97 °C
  });
  LabeledCloud scan;
  for (int i = 0; i < 100; ++i) scan.push_back(Eigen::Vector3f(0.01f * i, 0.0f, 5.0f));
  const ScanLabels labels = labeler.label(scan, realtimeSeconds(t_ns));
  late.join();
  EXPECT_EQ(labels.image_index.at(0), 1);
  std::size_t heat = 0;
  for (ClassId c : labels.classes) heat += c != 0;
  EXPECT_GT(heat, 50u);
  EXPECT_EQ(camera->stats().scans_without_image, 0u);
}

TEST(LiveCameraLabeler, RingKeepsFramesUntilNoLaterScanCanUseThem) {
  const CameraCalibration cam = smallCamera("ring", 8, 8);
  LiveCamera camera(cam);
  for (int i = 0; i < 5; ++i)
    camera.push(CameraFrame{std::int64_t(1000 + i) * 1'000'000'000, 8, 8, "mono8", false, 8, std::vector<std::uint8_t>(64)});
  camera.release(1002.5);  // scans from 1002.5 on: frame 1002 can still be nearest, 1000 and 1001 not
  const auto s = camera.snapshot();
  ASSERT_EQ(s->stamps().size(), 3u);
  EXPECT_DOUBLE_EQ(s->stamps().front(), 1002.0);
}

TEST(LiveCameraLabeler, LabelSpoolGivesTheSecondPassTheSameLabels) {
  // Scans labelled live are spooled; a second pass over the same scans gets the same classes,
  // property and named channels back, the camera class table, and no labels past the spool's end.
  const fs::path dir = scratchDir();
  const CameraCalibration cam = smallCamera("spool");
  auto camera = std::make_shared<LiveCamera>(cam);
  std::vector<std::uint8_t> pixels(64 * 48 * 2);
  for (std::size_t p = 0; p < pixels.size() / 2; ++p) pixels[2 * p + 1] = p % 64 < 32 ? 0x90 : 0x70;  // hot | cool
  ASSERT_TRUE(camera->push(CameraFrame{5'000'000'000, 64, 48, "mono16", false, 128, pixels}));
  LiveLabeler labeler({camera}, PropertyRules::defaults({"temperature"}, ClassTable::defaults()), LabelerConfig{});
  std::vector<Scan> scans(3);
  for (std::size_t s = 0; s < scans.size(); ++s) {
    scans[s].index = s;
    scans[s].stamp = 5.0 + 0.01 * double(s);
    for (int i = 0; i < 200; ++i) scans[s].cloud.push_back(Eigen::Vector3f(-2.0f + 0.02f * i, 0.1f * float(s), 5.0f));
  }
  struct Replay final : ScanSource {
    std::vector<Scan> scans;
    std::size_t next_ = 0;
    ClassTable table = ClassTable::defaults();
    std::optional<Scan> next() override { return next_ < scans.size() ? std::optional<Scan>(scans[next_++]) : std::nullopt; }
    std::optional<std::size_t> size() const override { return scans.size(); }
    const ClassTable& classTable() const override { return table; }
    std::string describe() const override { return "test scans"; }
  };
  Replay first;
  first.scans = {scans[0], scans[1]};  // the third came after the last label
  std::vector<Scan> live;
  {
    LiveLabelledScans labelled(first, labeler, dir / "labels.bin");
    while (auto s = labelled.next()) live.push_back(std::move(*s));
    labelled.flush();
  }
  auto second = std::make_unique<Replay>();
  second->scans = scans;
  const auto again = relabelFromSpool(std::move(second), dir / "labels.bin");
  for (std::size_t s = 0; s < 3; ++s) {
    const auto scan = again->next();
    ASSERT_TRUE(scan);
    if (s == 2) {
      EXPECT_FALSE(scan->cloud.hasProperty());
      break;
    }
    EXPECT_EQ(scan->cloud.classes, live[s].cloud.classes);
    ASSERT_EQ(scan->channels.size(), 1u);
    EXPECT_EQ(scan->channels[0].name, "temperature");
    std::size_t heat = 0;
    for (std::size_t i = 0; i < scan->cloud.size(); ++i) {
      EXPECT_TRUE(std::isnan(live[s].cloud.property[i]) ? std::isnan(scan->cloud.property[i])
                                                         : scan->cloud.property[i] == live[s].cloud.property[i]);
      heat += scan->cloud.classes[i] != 0;
    }
    EXPECT_GT(heat, 10u);
    EXPECT_LT(heat, 190u);
  }
  for (ClassId id : again->classTable().ids())
    if (again->classTable().isProperty(id)) EXPECT_FALSE(again->classTable().at(id).whole_extent);
  // A spool that is not one: a one-line error naming it.
  writeTextAtomically(dir / "bad.bin", "not a spool");
  auto third = std::make_unique<Replay>();
  EXPECT_THROW(relabelFromSpool(std::move(third), dir / "bad.bin"), Error);
}

}  // namespace
}  // namespace hazmap::test
