#pragma once
// `hazmap demo --live`: the live view in one command. A short simulated mission is written as
// VLP-16 packets to a temporary capture, replayed on loopback by a child `hazmap replay`, and
// received by a `hazmap live` session in this process, which prints the page's address; when the
// replay ends (or on Ctrl-C) the session writes its run folder.
#include <cstdint>
#include <filesystem>
#include <string>

#include "live_session.hpp"

namespace hazmap::cli {

struct LiveDemoOptions {
  std::string scenario = "naraha";
  std::uint64_t seed = 1;
  std::size_t frames = 0;  ///< 0 = the whole route
  std::string rate = "20";  ///< replay speed over the simulated clock (its frames are 10 s apart)
  LiveOptions live;        ///< out, listen, token, … (the sensor and its port are set here)
};

void runLiveDemo(LiveDemoOptions o, const ParameterOptions& params);

}  // namespace hazmap::cli
