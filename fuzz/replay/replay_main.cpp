// Fuzz replay: every fuzz target's seeds and a fixed number of deterministic mutants of them
// (mutate.hpp), in the normal build and so in `make test` (and under ASan in `make asan`).
// libFuzzer's coverage-guided run with ASan + UBSan needs clang and a second build: `make fuzz`.
//   hazmap_fuzz_replay TARGET SEED_DIR [MUTANTS]     exit 0, or 1 naming the input that failed
// A crash (abort, segfault, an exception other than hazmap::Error escaping the target) writes
// the input to ./replay-crash-TARGET, which `fuzz_TARGET replay-crash-TARGET` re-runs.
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "mutate.hpp"
#include "targets.hpp"

namespace fs = std::filesystem;

namespace {

using Entry = int (*)(const std::uint8_t*, std::size_t);
struct Target {
  const char* name;
  Entry entry;
};
#define HAZMAP_FUZZ_ROW(name) Target{#name, &hazmapFuzz_##name},
constexpr Target kTargets[] = {HAZMAP_FUZZ_REPLAY_TARGETS(HAZMAP_FUZZ_ROW)};
#undef HAZMAP_FUZZ_ROW

// What the signal handler writes out: the input being run and the file it goes to.
const std::vector<std::uint8_t>* g_input = nullptr;
char g_crash_path[256] = "replay-crash";

void writeCurrentInput() {
  const int fd = ::open(g_crash_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0 || g_input == nullptr) return;
  const std::size_t n = g_input->size();
  for (std::size_t done = 0; done < n;) {
    const ssize_t w = ::write(fd, g_input->data() + done, n - done);
    if (w <= 0) break;
    done += static_cast<std::size_t>(w);
  }
  ::close(fd);
}

extern "C" void onCrash(int sig) {
  writeCurrentInput();  // open/write/close are async-signal-safe
  const char msg[] = "fuzz replay: crash; the input is in ./";
  (void)!::write(2, msg, sizeof msg - 1);
  (void)!::write(2, g_crash_path, std::strlen(g_crash_path));
  (void)!::write(2, "\n", 1);
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

std::vector<std::uint8_t> readBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<fs::path> seedFiles(const fs::path& dir) {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file()) files.push_back(e.path());
  std::sort(files.begin(), files.end());  // directory order is the file system's: fix it
  return files;
}

/// Runs one input; false (with a message) when the target let an exception escape.
bool runOne(const Target& t, const std::vector<std::uint8_t>& input, const std::string& what) {
  g_input = &input;
  try {
    t.entry(input.data(), input.size());
    return true;
  } catch (const std::exception& e) {
    writeCurrentInput();
    std::fprintf(stderr, "fuzz replay %s: %s: exception escaped the target: %s (input in ./%s)\n", t.name,
                 what.c_str(), e.what(), g_crash_path);
  } catch (...) {
    writeCurrentInput();
    std::fprintf(stderr, "fuzz replay %s: %s: unknown exception escaped the target (input in ./%s)\n", t.name,
                 what.c_str(), g_crash_path);
  }
  return false;
}

int replay(const Target& t, const fs::path& dir, std::size_t mutants) {
  const auto files = seedFiles(dir);
  if (files.empty()) {
    std::fprintf(stderr, "fuzz replay %s: %s: no seed files\n", t.name, dir.c_str());
    return 1;
  }
  std::vector<std::vector<std::uint8_t>> seeds;
  for (const auto& f : files) seeds.push_back(readBytes(f));
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t s = 0; s < seeds.size(); ++s)
    if (!runOne(t, seeds[s], "seed " + files[s].filename().string())) return 1;
  for (std::size_t k = 0; k < mutants; ++k) {
    const std::size_t s = k % seeds.size();
    const auto input = hazmap::fuzz::mutate(seeds[s], k / seeds.size());
    if (!runOne(t, input, "mutant " + std::to_string(k / seeds.size()) + " of " + files[s].filename().string()))
      return 1;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("OK: fuzz replay %s: %zu seeds and %zu mutants in %.1f s\n", t.name, seeds.size(), mutants, seconds);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3 || argc > 4) {
    std::fprintf(stderr, "usage: hazmap_fuzz_replay TARGET SEED_DIR [MUTANTS]\n");
    return 2;
  }
  const std::string name = argv[1];
  const Target* target = nullptr;
  for (const auto& t : kTargets)
    if (name == t.name) target = &t;
  if (target == nullptr) {
    std::fprintf(stderr, "hazmap_fuzz_replay: unknown target '%s'\n", name.c_str());
    return 2;
  }
  const fs::path dir = argv[2];
  if (!fs::is_directory(dir)) {
    std::fprintf(stderr, "hazmap_fuzz_replay: %s: not a directory\n", dir.c_str());
    return 2;
  }
  const std::size_t mutants = argc == 4 ? std::stoul(argv[3]) : 2000;
  spdlog::set_level(spdlog::level::off);  // the decoders' "tolerated" warnings, thousands of them
  std::snprintf(g_crash_path, sizeof g_crash_path, "replay-crash-%s", name.c_str());
  for (const int sig : {SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGILL}) std::signal(sig, onCrash);
  return replay(*target, dir, mutants);
}
