#include "hazmap/properties/bag_images.hpp"

#include <algorithm>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/ros_messages.hpp"

namespace hazmap {

std::shared_ptr<MemoryImages> readBagImages(const std::filesystem::path& bag, const CameraCalibration& camera,
                                            std::string topic) {
  if (topic.empty()) topic = camera.topic;
  if (topic.empty()) fail(camera.source.string(), "no image topic (set 'topic:' in the camera YAML)");
  auto reader = openBag(bag);
  const auto& topics = reader->topics();
  const auto it = std::find_if(topics.begin(), topics.end(), [&](const TopicInfo& t) { return t.name == topic; });
  if (it == topics.end()) fail(bag.string(), "has no topic " + topic);
  const bool compressed = it->type == "sensor_msgs/msg/CompressedImage";
  if (it->type != "sensor_msgs/msg/Image" && !compressed)
    fail(bag.string(), "topic " + topic + " is " + it->type + ", not sensor_msgs/msg/Image or CompressedImage");
  reader->selectTopics({topic});
  // Messages come in log-time order; header stamps may not: sort by stamp.
  std::vector<PropertyImage> images;
  BagMessage msg;
  while (reader->next(msg)) {
    const std::string where = bag.string() + ": " + topic + " message " + std::to_string(images.size());
    const auto s = msg.topic->serialization;
    images.push_back(compressed ? imageFromCompressed(decodeCompressedImage(msg.data, s, where), camera, where)
                                : imageFromMessage(decodeImage(msg.data, s, where), camera, where));
  }
  std::stable_sort(images.begin(), images.end(), [](const auto& a, const auto& b) { return a.stamp < b.stamp; });
  auto out = std::make_shared<MemoryImages>();
  for (auto& img : images) out->add(std::move(img));
  return out;
}

}  // namespace hazmap
