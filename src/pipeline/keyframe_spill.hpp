#pragma once
// Keyframe clouds of a stream that cannot be read again (a bag, a capture), kept on disk instead
// of in memory: the loop detector holds only its newest keyframes and reloads older ones from
// here when a loop candidate needs them, as it re-reads a sequence folder's scans.
#include <filesystem>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap {

class KeyframeSpill {
 public:
  /// A fresh folder under the system's temporary folder, removed with the object.
  KeyframeSpill();
  ~KeyframeSpill();
  KeyframeSpill(const KeyframeSpill&) = delete;
  KeyframeSpill& operator=(const KeyframeSpill&) = delete;

  /// Stores frame `frame`'s cloud (every channel, bit for bit).
  void store(std::size_t frame, const LabeledCloud& cloud);
  LabeledCloud load(std::size_t frame, const ClassTable& table) const;

 private:
  std::filesystem::path fileOf(std::size_t frame) const;
  std::filesystem::path dir_;
};

}  // namespace hazmap
