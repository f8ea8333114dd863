// hazmap live's session: the stream, the pipeline, the live view, saves (on request, every
// --autosave-every seconds, at the end). See live_session.hpp.
#include "live_session.hpp"

#include "background_saves.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <iostream>
#include <memory>
#include <mutex>
#include <unistd.h>

#include "hazmap/core/error.hpp"
#include "hazmap/core/memory.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/pipeline/frame_latency.hpp"
#include "hazmap/pipeline/live_save_map.hpp"
#include "hazmap/pipeline/live_view_feed.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "hazmap/properties/live_labels.hpp"
#include "hazmap/sources/live_source.hpp"

namespace hazmap::cli {
namespace {

std::atomic<bool> g_stop{false};
volatile std::sig_atomic_t g_signal = 0;

/// First SIGINT/SIGTERM: end the stream (the run folder is written); a second: abort now.
extern "C" void onSignal(int signal) {
  if (g_stop.load()) ::_exit(128 + signal);
  g_signal = signal;
  g_stop.store(true);
}

void installSignalHandlers() {
  struct sigaction action {};
  action.sa_handler = onSignal;
  sigemptyset(&action.sa_mask);
  ::sigaction(SIGINT, &action, nullptr);
  ::sigaction(SIGTERM, &action, nullptr);
}

SlamConfig liveConfig(const LiveOptions& o, const ParameterOptions& params) {
  SlamConfig config = SlamConfig::forMethod(parseSlamMethod(o.method));
  config.back_end = BackEndSchedule::OwnThread;  // live: tracking never waits for a loop stage
  if (!o.config.empty()) config.applyYamlFile(o.config);
  config.property_icp = params.propertyIcp(config.property_icp);
  params.applySettings(config);
  config.threads = o.threads;
  config.deskew.enabled = !o.no_deskew;
  return config;
}

ScanSourceOptions sourceOptions(const LiveOptions& o, LiveSensor sensor) {
  ScanSourceOptions s;
  s.sensor_metadata = o.sensor_metadata;
  if (sensor == LiveSensor::Velodyne) s.velodyne_calibration = o.calibration;
  if (sensor == LiveSensor::Hesai) s.hesai_calibration = o.calibration;
  // A model name (VLP-16, Pandar64) is passed on: packets of another model are then counted.
  const std::string family = toString(sensor);
  const bool named_family = std::equal(o.sensor.begin(), o.sensor.end(), family.begin(), family.end(),
                                       [](char a, char b) { return std::tolower(static_cast<unsigned char>(a)) == b; });
  if (!named_family) s.sensor = o.sensor;
  if (!o.classes.empty()) s.class_table = ClassTable::load(o.classes);
  s.notice = [](const std::string& line) { std::cerr << "notice: " << line << "\n"; };
  return s;
}

std::string stoppedBy() {
  return std::string("stopped by ") + (g_signal == SIGTERM ? "SIGTERM" : g_signal == SIGINT ? "SIGINT" : "end of stream");
}

nlohmann::json latencyJson(const FrameLatency& l) {
  return {{"frames", l.count()}, {"p50", l.quantileMs(0.5)}, {"p99", l.quantileMs(0.99)}, {"max", l.maxMs()}};
}

nlohmann::json liveJson(const LiveScanSource& source, LiveSensor sensor, const std::string& state,
                        const FrameLatency& latency) {
  const LiveStats s = source.stats();
  return {{"latency_ms", latencyJson(latency)}, {"sensor", toString(sensor)}, {"data_port", source.dataPort()},
          {"auxiliary_port", source.auxiliaryPort()}, {"received", s.receiver.received},
          {"kernel_dropped", s.receiver.kernel_dropped}, {"queue_dropped", s.receiver.queue_dropped},
          {"truncated", s.receiver.truncated}, {"lost", s.lost}, {"scans_skipped", s.scans_skipped},
          {"silences", s.silences}, {"decoder", s.decoder}, {"spool", "live.pcap"}, {"state", state}};
}

constexpr const char* kLabelSpool = "live_labels.bin";
// How often the pipeline's thread gives free memory back (releaseFreedMemory): a trim takes
// milliseconds and the next frame faults its scratch pages in again, so not every frame.
constexpr std::chrono::seconds kReleaseFreedMemoryEvery{30};

/// POST /save from the browser: answered once a save whose snapshot the pipeline took after the
/// request (between two frames: a snapshot needs the pipeline's thread) is written, or after
/// `wait` with `pending`.
class SaveRequests {
 public:
  std::string request(std::chrono::seconds wait) {
    std::unique_lock<std::mutex> lock(m_);
    if (ended_) return answer_;  // the run folder was written at the end
    const std::uint64_t ticket = ++requested_;
    if (!done_.wait_for(lock, wait, [&] { return served_ >= ticket || ended_; }))
      return R"({"saved":false,"pending":true,"reason":"no frame since the request (is the sensor silent?): the save runs with the next frame or at the end"})";
    return answer_;
  }
  /// The requests a save starting now serves (0: none waiting).
  std::uint64_t waiting() {
    std::lock_guard<std::mutex> lock(m_);
    return requested_ > served_ ? requested_ : 0;
  }
  /// `upto` = waiting() when the save started; `final_write`: later requests get this answer too.
  void answer(std::uint64_t upto, std::string text, bool final_write) {
    {
      std::lock_guard<std::mutex> lock(m_);
      served_ = std::max(served_, upto);
      answer_ = std::move(text);
      ended_ = ended_ || final_write;
    }
    done_.notify_all();
  }

 private:
  std::mutex m_;
  std::condition_variable done_;
  std::uint64_t requested_ = 0, served_ = 0;
  std::string answer_;
  bool ended_ = false;
};

/// One save: what run.json says of the stream, taken between two frames on the pipeline's thread,
/// and the result of the frames so far (while running, from the back end's thread once its graph
/// has them); written on the pipeline's thread (at the end) or on the saver's (while running).
struct SaveJob {
  SlamResult result;
  nlohmann::json live;  ///< run.json's "live"
  std::string state;
  std::uint64_t requests = 0;  ///< the POST /save requests it answers (SaveRequests::waiting)
  std::chrono::steady_clock::time_point taken = std::chrono::steady_clock::now();  ///< the state's moment
  bool segments_only = false;  ///< write only if the saves' map can be composed (no rebuild)
};

struct Session {
  const LiveOptions& o;
  SlamConfig config;
  LiveSensor sensor;
  std::unique_ptr<LiveScanSource> source;
  std::unique_ptr<LiveCameras> cameras;        // with --camera
  std::unique_ptr<LiveLabelledScans> labelled;  // the source's scans with the cameras' labels
  std::unique_ptr<LiveViewFeed> view;
  std::unique_ptr<LiveSaveMap> save_map;  // the saves' map while running (none: no saves then)
  SaveRequests saves;
  FrameLatency latency;  // a scan's newest point to its pose (pipeline thread only)

  SaveJob job(SlamResult result, std::string state);
  void write(const SaveJob& job, bool final_write);
  void save(const SaveJob& job, bool final_write);
  void saveEndQuickly(const SlamResult& result);
  void startView();
  ScanSource& scans() { return labelled ? static_cast<ScanSource&>(*labelled) : *source; }
};

/// Between two frames (the pipeline's thread): the spools flushed up to this scan, the stream's
/// counts read. The save then reads only what is flushed (the receiver appends behind it).
SaveJob Session::job(SlamResult result, std::string state) {
  source->flushSpool();
  if (labelled) labelled->flush();
  SaveJob job{std::move(result), liveJson(*source, sensor, state, latency), std::move(state), saves.waiting()};
  if (cameras) job.live["cameras"] = cameras->json(), job.live["label_spool"] = kLabelSpool;
  return job;
}

/// The run folder from the job's result (the end's or a save's). While running, the map is
/// composed from the segments built beside tracking (pipeline/live_save_map.hpp: its cost follows
/// the map, not the mission); at the end, or when those gave up, the map's second pass re-reads
/// the spool as `hazmap run` does. run.json gains the stream's counts (`live`).
void Session::write(const SaveJob& job, bool final_write) {
  const std::filesystem::path out(o.out);
  OutputConfig outputs;
  outputs.write_viewer = !o.no_viewer;
  if (cameras) outputs.channel_cameras = cameras->channelCameras();
  outputs.write_map_folder = final_write;  // the reopenable map once, at the end (not every autosave)
  std::optional<GlobalMap> composed;
  if (!final_write && save_map) composed = save_map->compose(job.result.estimate.size(), job.result.estimate.poses);
  if (!composed && job.segments_only) return;
  RunSummary summary;
  if (composed) {
    summary = writeRunOutputs(*composed, job.result, config, outputs, out);
  } else {
    ScanSourceOptions options = sourceOptions(o, sensor);
    options.notice = nullptr;  // the live pass said it already
    std::unique_ptr<ScanSource> second_pass = openLiveSpool(out / "live.pcap", sensor, options);
    if (labelled) second_pass = relabelFromSpool(std::move(second_pass), out / kLabelSpool);
    summary = writeRunOutputs(*second_pass, job.result, config, outputs, out);
  }
  nlohmann::json j = nlohmann::json::parse(readTextFile(out / "run.json"));
  j["live"] = job.live;
  j["live"]["map"] = composed ? fmt::format("re-placed from {} segments built while running", save_map->segments())
                              : std::string("rebuilt from the spool");
  writeTextAtomically(out / "run.json", j.dump(2) + "\n");
  if (o.quiet) return;
  if (final_write) std::cout << formatRunSummary(job.result, summary, out, outputs);
  else if (job.state.starts_with("stopped"))
    std::cout << fmt::format("wrote {} frames to {} (the map re-placed); rebuilding the map from {}\n",
                             job.result.frames.size(), o.out, (out / "live.pcap").string())
              << std::flush;
  else std::cout << fmt::format("{} {} frames to {}\n", job.state.starts_with("autosave") ? "autosaved" : "saved on request",
                                job.result.frames.size(), o.out)
                 << std::flush;
}

/// At the end, before the map's exact rebuild (minutes after an hour): the final state at once
/// with the segments' map, so a second signal or a power cut meanwhile finds the final poses
/// and a consistent folder, not an autosave up to a minute old.
void Session::saveEndQuickly(const SlamResult& result) {
  if (!save_map || !save_map->complete()) return;
  save_map->cut(result.estimate.size());
  SaveJob quick = job(SlamResult(result), stoppedBy() + "; the map re-placed, being rebuilt");
  quick.segments_only = true;
  save(quick, false);
}

/// write(), told to the browsers (the saved hazards and trajectory) and to a waiting POST /save.
void Session::save(const SaveJob& job, bool final_write) {
  const std::uint64_t requests = job.requests;
  const SlamResult& result = job.result;
  nlohmann::json answer;
  try {
    if (view) view->setState("saving");
    const auto started = std::chrono::steady_clock::now();
    write(job, final_write);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    const auto folder = std::filesystem::absolute(o.out).lexically_normal();
    const std::vector<Hazard> hazards = readHazardsJson(folder / "hazards.json");
    if (view) view->showSaved(hazards, result.estimate, folder.string(), LiveViewFeed::SaveTiming{result.frames.size(), job.taken, seconds});
    answer = {{"saved", folder.string()}, {"frames", result.frames.size()}, {"hazards", hazards.size()}, {"state", job.state}};
  } catch (const std::exception& e) {  // hazmap::Error, and a full disk's filesystem_error alike
    if (view) view->showSaveError(e.what());
    answer = {{"saved", false}, {"error", e.what()}};
    if (final_write) {
      saves.answer(requests, answer.dump(), true);
      throw;
    }
    std::cerr << "notice: save failed: " << e.what() << "\n";
  }
  if (view) view->setState(final_write ? job.state : "");
  if (requests > 0 || final_write) saves.answer(requests, answer.dump(), final_write);
}

std::string readToken(const LiveOptions& o) {
  if (!o.token.empty() && !o.token_file.empty()) fail("--token-file", "give --token or --token-file, not both");
  std::string token = o.token;
  if (!o.token_file.empty()) {
    token = readTextFile(o.token_file);
    token.erase(std::find_if(token.begin(), token.end(), [](char c) { return c == '\n' || c == '\r'; }), token.end());
    if (token.empty()) fail(o.token_file, "the token file's first line is empty");
  }
  const bool url_safe = std::all_of(token.begin(), token.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' || c == '~';
  });
  if (!token.empty() && (token.size() < 8 || token.size() > 200 || !url_safe))
    fail(o.token_file.empty() ? "--token" : o.token_file,
         "a token is 8 to 200 characters of A-Z a-z 0-9 - _ . ~ (it travels in the page's address)");
  return token;
}

void Session::startView() {
  if (o.no_view) return;
  if (!(o.view_voxel >= 0.01 && o.view_voxel <= 10)) fail("--view-voxel", "must be in [0.01, 10] m");
  LiveViewFeedConfig c;
  c.server.listen = o.listen;
  c.server.token = readToken(o);
  c.map.voxel = o.view_voxel;
  c.map.max_points = o.view_max_points;
  c.title = "hazmap live: " + o.out;
  LiveScanSource* s = source.get();
  if (cameras) c.cameras = [this] { return cameras->stats(); };
  view = std::make_unique<LiveViewFeed>(c, scans().classTable(), [s] { return s->receiverStats(); },
                                        [this] { return saves.request(std::chrono::seconds(20)); });
  std::cout << "live view: " << liveViewUrl(o.listen, view->port(), c.server.token) << "\n" << std::flush;
}

}  // namespace

void addLiveViewOptions(CLI::App& app, LiveOptions& o) {
  app.add_option("--listen", o.listen,
                 "The live view's address ADDR:PORT (port 0: any free port); an address other than loopback "
                 "needs --token or --token-file");
  app.add_option("--token", o.token, "Every request to the live view must carry this token (?token=T or a Bearer header)");
  app.add_option("--token-file", o.token_file, "Read the token from this file's first line");
  app.add_flag("--no-view", o.no_view, "Run without the live view (no HTTP server)");
  app.add_option("--view-voxel", o.view_voxel, "The live view draws one map point per voxel this size (m)");
  app.add_option("--view-max-points", o.view_max_points, "The live view's map points, at most");
}

void stopLiveSession() { g_stop.store(true); }

void runLiveSession(const LiveOptions& o, const ParameterOptions& params,
                    const std::function<void(std::uint16_t)>& listening) {
  Session s{o, liveConfig(o, params), liveSensorNamed(o.sensor), nullptr, nullptr, nullptr, nullptr, nullptr, {}, {}};
  if (o.port < -1 || o.port > 65535) fail("--port", std::to_string(o.port) + " is no UDP port (0-65535)");
  if (!(o.queue_mb >= 0.01 && o.queue_mb <= 65536)) fail("--queue-mb", "must be in [0.01, 65536] MiB");
  if (!(o.autosave_every >= 0)) fail("--autosave-every", "must be >= 0 seconds (0: no autosave)");
  s.config.validate();
  if (!o.no_view) readToken(o);  // a bad token fails before anything binds
  const std::filesystem::path out(o.out);
  std::filesystem::create_directories(out);
  LiveSourceOptions live;
  live.sensor = s.sensor;
  if (o.port >= 0) live.port = static_cast<std::uint16_t>(o.port);
  live.spool = out / "live.pcap";
  live.stop = &g_stop;
  live.queue_bytes = static_cast<std::size_t>(o.queue_mb * 1024 * 1024);
  s.source = openLiveSource(live, sourceOptions(o, s.sensor));
  if (!o.cameras.cameras.empty() || !o.cameras.pipelines.empty()) {
    s.cameras = std::make_unique<LiveCameras>(o.cameras, s.source->classTable());
    s.labelled = std::make_unique<LiveLabelledScans>(*s.source, s.cameras->labeler(), out / kLabelSpool);
  } else if (!o.cameras.rules.empty()) {
    fail("--rules", "needs --camera");
  }
  if (!o.sensor_metadata.empty())  // beside the spool, so `hazmap run DIR/live.pcap` finds it
    std::filesystem::copy_file(o.sensor_metadata, out / "live.json", std::filesystem::copy_options::overwrite_existing);
  s.startView();
  // Autosaves need a map whose cost does not grow with the mission; without them a save on
  // request rebuilds it from the spool (and the session holds no segments).
  if (o.autosave_every > 0) s.save_map = std::make_unique<LiveSaveMap>(OutputConfig{}.map, s.scans().classTable());
  installSignalHandlers();
  std::cout << fmt::format("listening on UDP port {} ({}; auxiliary port {}); Ctrl-C ends the run and writes {}\n",
                           s.source->dataPort(), toString(s.sensor), s.source->auxiliaryPort(), o.out)
            << std::flush;
  if (listening) listening(s.source->dataPort());
  // Saves while running write on their own thread (a save re-reads the whole spool: its cost
  // grows with the mission); the interval counts from the end of the last one.
  BackgroundSaves<SaveJob> saver([&s](SaveJob& job) {
    try {
      s.save(job, false);
    } catch (const std::exception& e) {
      std::cerr << "notice: save failed: " << e.what() << "\n";
    }
    releaseFreedMemory();  // the save's map, freed in the middle of the heap
  });
  auto last_release = std::chrono::steady_clock::now();
  SlamSnapshots hooks;
  hooks.due = [&] {
    if (saver.busy()) return false;
    const double since = std::chrono::duration<double>(std::chrono::steady_clock::now() - saver.lastEnded()).count();
    return s.saves.waiting() > 0 || (o.autosave_every > 0 && since >= o.autosave_every);
  };
  // The save's state (spools flushed, the stream's counts, the saves' map cut) at the frame the
  // snapshot ends with; its result comes later, from the back end's thread once it has that frame
  // (tracking does not wait for it: a solve of a long mission's graph takes seconds).
  SaveJob next_save;
  hooks.taking = [&](std::size_t frames) {
    const char* state = s.saves.waiting() > 0 ? "saved on request while running" : "autosave while running";
    if (s.save_map) s.save_map->cut(frames);
    next_save = s.job(SlamResult{}, state);
  };
  hooks.take = [&](SlamResult snapshot) {
    next_save.result = std::move(snapshot);
    saver.submit(std::move(next_save));
  };
  hooks.frame = [&](const SlamFrameEvent& e) {
    std::optional<double> latency;
    if (const double newest = newestPointTime(e.scan); newest > 0) latency = realtimeNow() - newest;
    if (latency) s.latency.add(*latency);
    if (s.view) s.view->onFrame(e, latency);
    if (s.save_map) s.save_map->frame(e, s.labelled ? std::span<const PointChannel>(s.labelled->lastChannels()) : std::span<const PointChannel>{});
    // A long mission's resident memory follows what is in use (core/memory.hpp); the cost, one
    // frame's page faults again, is paid once per interval.
    if (std::chrono::steady_clock::now() - last_release >= kReleaseFreedMemoryEvery) {
      releaseFreedMemory();
      last_release = std::chrono::steady_clock::now();
    }
  };
  SlamResult result = runSlam(s.scans(), s.config, {}, hooks);
  saver.finish();  // one writer of the run folder at a time
  if (s.view) s.view->drain();
  s.saveEndQuickly(result);
  s.save_map.reset();  // the end rebuilds the map from the spool
  s.save(s.job(std::move(result), stoppedBy()), true);
}

}  // namespace hazmap::cli
