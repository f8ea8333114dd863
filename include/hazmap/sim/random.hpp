#pragma once
// Counter-seeded random numbers for the simulator. Every frame gets its own generator seeded
// from (seed, stream, frame index), so results do not depend on the order in which frames are
// generated (parallelism) nor on how many frames are requested. The distributions are written
// out here rather than taken from <random>, whose normal/uniform algorithms differ between
// standard libraries: the same seed gives the same bytes with any compiler.
#include <cmath>
#include <cstdint>

#include "hazmap/core/hash.hpp"

namespace hazmap::sim {

/// Independent random streams of one simulation.
enum class RngStream : std::uint64_t { Scan = 1, Odometry = 2, Temperature = 3, Camera = 4, Calibration = 5, Upset = 6, Imu = 7, ImuStream = 8 };

class Rng {
 public:
  Rng(std::uint64_t seed, RngStream stream, std::uint64_t index) {
    state_ = splitmix64Mix(seed ^ 0x6a09e667f3bcc909ULL);
    state_ = splitmix64Mix(state_ ^ (static_cast<std::uint64_t>(stream) * 0xbb67ae8584caa73bULL));
    state_ = splitmix64Mix(state_ ^ (index * 0x3c6ef372fe94f82bULL + 0xa54ff53a5f1d36f1ULL));
  }

  /// splitmix64: full-period 64-bit generator, passes BigCrush.
  std::uint64_t next() {
    return splitmix64Mix(state_ += 0x9e3779b97f4a7c15ULL);
  }
  /// Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  bool bernoulli(double p) { return uniform() < p; }
  /// Standard normal (Box–Muller; the second value is kept for the next call).
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - uniform();  // (0, 1]
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    const double a = 2.0 * 3.14159265358979323846 * u2;
    spare_ = r * std::sin(a);
    has_spare_ = true;
    return r * std::cos(a);
  }
  double normal(double sigma) { return sigma * normal(); }
  /// Uniform integer in [0, n).
  std::uint64_t below(std::uint64_t n) { return n == 0 ? 0 : next() % n; }

 private:
  std::uint64_t state_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace hazmap::sim
