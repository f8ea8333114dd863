#pragma once
// Keyframe clouds kept on disk instead of in memory: the loop detector's, for a stream that cannot
// be read again (a bag, a capture), reloaded when a loop candidate needs them, as it re-reads a
// sequence folder's scans; tracking's whole-map keyframes beyond the resident ones
// (RecoveryConfig::resident_keyframes), reloaded when the whole map is built.
#include <filesystem>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap {

class KeyframeSpill {
 public:
  /// A fresh folder under the system's temporary folder (TMPDIR), removed with the object; the
  /// folders left by processes that ended without removing theirs are removed first.
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

/// Removes the keyframe folders under `base` whose process no longer exists (a kill -9, a power
/// cut); KeyframeSpill's constructor calls it.
void removeStaleKeyframeSpills(const std::filesystem::path& base);

}  // namespace hazmap
