#include "hazmap/pipeline/progress.hpp"

#include <unistd.h>

#include <cstdio>

namespace hazmap {

ProgressBar::ProgressBar(std::string label, std::size_t total, int enabled)
    : label_(std::move(label)),
      total_(total),
      enabled_(enabled < 0 ? ::isatty(STDERR_FILENO) == 1 : enabled == 1),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_ - std::chrono::seconds(1)) {}

ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::update(std::size_t done) {
  if (!enabled_ || finished_) return;
  const auto now = std::chrono::steady_clock::now();
  if ((total_ == 0 || done < total_) && now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double fps = elapsed > 0 ? static_cast<double>(done) / elapsed : 0.0;
  if (total_ == 0) {  // a stream of unknown length (a bag, a capture): no bar, no ETA
    std::fprintf(stderr, "\r%-18s %zu frames  %6.1f frames/s", label_.c_str(), done, fps);
    std::fflush(stderr);
    return;
  }
  const double eta = fps > 0 && total_ > done ? static_cast<double>(total_ - done) / fps : 0.0;
  constexpr int kWidth = 30;
  const int filled = total_ ? static_cast<int>(kWidth * done / total_) : kWidth;
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.resize(kWidth, '.');
  std::fprintf(stderr, "\r%-18s [%s] %zu/%zu frames  %6.1f frames/s  ETA %4.0f s", label_.c_str(),
               bar.c_str(), done, total_, fps, eta);
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (!enabled_ || finished_) return;
  finished_ = true;
  std::fprintf(stderr, "\n");
}

}  // namespace hazmap
