// Temporary: the MCAP and ROS 1 readers land in the next commits.
#include "bag_readers.hpp"
#include "hazmap/core/error.hpp"

namespace hazmap::sources {
std::unique_ptr<MessageReader> openRos1Bag(const std::filesystem::path& file) {
  fail(file.string(), "ROS 1 bag reading is not implemented yet");
}
}  // namespace hazmap::sources
