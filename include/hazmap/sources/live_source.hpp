#pragma once
// A LiDAR on the network as a ScanSource (`hazmap live`): UDP datagrams from a receive thread
// (udp_receiver.hpp) through the same packet decoders and scan assembly a capture goes through,
// so the pipeline downstream is the one `hazmap run` drives. Every datagram is also written to a
// spool capture; the map's second pass (and an autosave's) re-reads the spool with
// openLiveSpool, which cuts the same scans. When datagrams were lost (kernel or queue overflow)
// the scan they fell into is skipped, not passed on with a hole; the spool marks the loss so its
// re-reading skips the same scan.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "hazmap/sources/scan_source.hpp"
#include "hazmap/sources/udp_receiver.hpp"

namespace hazmap {

enum class LiveSensor { Velodyne, Hesai, Ouster };
/// "velodyne", "hesai", "ouster" (any case), or a model name --sensor accepts elsewhere
/// ("VLP-16", "Pandar64", …: its family). Throws hazmap::Error naming --sensor otherwise.
LiveSensor liveSensorNamed(const std::string& name);
const char* toString(LiveSensor sensor);
/// The sensor's standard ports: data (Velodyne and Hesai 2368, Ouster 7502) and auxiliary
/// (Velodyne position 8308, Hesai GPS 10110, Ouster IMU 7503).
std::uint16_t standardDataPort(LiveSensor sensor);
std::uint16_t standardAuxiliaryPort(LiveSensor sensor);

/// The UDP port that marks lost datagrams in a spool (the discard service's).
inline constexpr std::uint16_t kSpoolLossPort = 9;

struct LiveSourceOptions {
  LiveSensor sensor = LiveSensor::Velodyne;
  /// Data port; nullopt: the standard one. The auxiliary port is then the standard one too,
  /// else data port + 1 (as `hazmap replay --port` sends). 0: any free port (tests).
  std::optional<std::uint16_t> port;
  std::filesystem::path spool;  ///< capture of every datagram received (created)
  std::size_t queue_bytes = std::size_t{256} << 20;
  const std::atomic<bool>* stop = nullptr;  ///< set (by a signal): the stream ends
  /// A sensor silent for longer than this (s) is reported once as `waiting for sensor`.
  double silence_seconds = 1.0;
};

struct LiveStats {
  UdpReceiverStats receiver;
  std::uint64_t lost = 0;           ///< datagrams lost before reaching the decoder (kernel + queue)
  std::uint64_t scans_skipped = 0;  ///< scans a loss fell into: skipped, not corrupted
  std::uint64_t silences = 0;       ///< times the sensor went silent for > silence_seconds
  std::string decoder;              ///< the decoder's description with what it tolerated
};

class LiveScanSource : public ScanSource {
 public:
  virtual LiveStats stats() const = 0;
  /// The receive thread's counts and queue now; unlike stats(), safe from any thread (the live
  /// view's status line reads it while the pipeline waits for the sensor).
  virtual UdpReceiverStats receiverStats() const = 0;
  /// The spool made readable up to now (for an autosave's second pass).
  virtual void flushSpool() = 0;
  virtual std::uint16_t dataPort() const = 0;
  virtual std::uint16_t auxiliaryPort() const = 0;
};

/// Binds the ports and starts receiving. `options` carries the sensor's metadata (Ouster: needed)
/// or calibration, the class table and the notice sink (`waiting for sensor` goes there too).
/// Throws hazmap::Error: a port in use, an Ouster sensor without metadata.
std::unique_ptr<LiveScanSource> openLiveSource(const LiveSourceOptions& live, const ScanSourceOptions& options);
/// A live run's spool read back: the same scans the live source gave.
std::unique_ptr<ScanSource> openLiveSpool(const std::filesystem::path& spool, LiveSensor sensor,
                                          const ScanSourceOptions& options);

}  // namespace hazmap
