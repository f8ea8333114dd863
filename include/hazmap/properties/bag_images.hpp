#pragma once
// Property images from a bag's sensor_msgs/Image or CompressedImage topic (MCAP, rosbag2, ROS 1), decoded into the
// camera's channel units; stamps are the messages' header stamps (the camera's clock).
#include <filesystem>
#include <memory>
#include <string>

#include "hazmap/properties/labeler.hpp"

namespace hazmap {

/// Reads every image of `topic` (empty = the camera's `topic:`). Throws hazmap::Error naming
/// the bag for a missing topic or a topic of another type, and naming the message (topic and
/// index) for an image of the wrong size or encoding.
std::shared_ptr<MemoryImages> readBagImages(const std::filesystem::path& bag, const CameraCalibration& camera,
                                            std::string topic = "");

}  // namespace hazmap
