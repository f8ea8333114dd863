#pragma once
// Internal to the Velodyne decoder (velodyne_decoder.cpp: packets, scan cutting;
// velodyne_blocks.cpp: the models' block layouts, timing and geometry).
#include <array>
#include <cmath>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "hazmap/sources/velodyne.hpp"

namespace hazmap::velodyne_detail {

constexpr int kBlocks = 12;
constexpr int kBlockBytes = 100;
constexpr int kCentiDegrees = 36000;
constexpr std::uint8_t kModeStrongest = 0x37, kModeLast = 0x38, kModeDual = 0x39;
constexpr std::uint16_t kBankIds[4] = {0xEEFF, 0xDDFF, 0xCCFF, 0xBBFF};

inline std::uint16_t u16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}

/// Bank (0–3) of a VLS-128 block header, -1 if the header is no bank id.
inline int bankOf(std::uint16_t header) {
  for (int i = 0; i < 4; ++i)
    if (kBankIds[i] == header) return i;
  return -1;
}

/// cos/sin of every azimuth the packets can carry (0.01° steps), as the drivers tabulate them.
struct AzimuthTable {
  std::vector<float> cos_az, sin_az;
  AzimuthTable() : cos_az(kCentiDegrees), sin_az(kCentiDegrees) {
    for (int i = 0; i < kCentiDegrees; ++i) {
      const float rad = static_cast<float>(0.01 * i * M_PI / 180.0);
      cos_az[i] = std::cos(rad);
      sin_az[i] = std::sin(rad);
    }
  }
};
const AzimuthTable& azimuthTable();

/// A laser's correction in the form the inner loop uses (floats, like the drivers).
struct LaserTerms {
  float cos_vert, sin_vert;
  double rot_cd;  // rot_correction in 0.01°
  float dist, dist_x, dist_y, vert_offset, horiz_offset;
  float min_intensity, max_intensity, focal_offset, focal_slope;
  bool two_point;
  std::uint16_t ring;
};

std::vector<LaserTerms> laserTerms(const VelodyneCalibration& cal);
/// The rotor azimuth of a block and how far the rotor turns until the next block (0.01°), as
/// the drivers estimate them: from the next block of the same return, the last blocks of a
/// packet reusing the previous difference (or none for the very last one).
struct BlockAzimuths {
  std::uint16_t azimuth[kBlocks];
  float diff[kBlocks];
};

BlockAzimuths blockAzimuths(const std::uint8_t* packet, int used_blocks, bool dual,
                            int last_block_without_diff);

class VelodyneDecoder final : public PacketDecoder {
 public:
  explicit VelodyneDecoder(const VelodyneOptions& options);

  void addPacket(std::span<const std::uint8_t> payload, double packet_time,
                 const std::string& where) override;
  std::optional<DecodedScan> takeScan() override;
  std::optional<DecodedScan> flush() override;
  std::string describe() const override;

 private:
  void setUp(VelodyneModel model);
  void decodePacket(const std::uint8_t* packet, double packet_time, const std::string& where);
  enum class Cut { None, BeforePacket, WithinPacket };
  Cut findCut(const std::uint8_t* packet);
  void cutScan(bool move_tail);
  bool inFov(int azimuth_cd) const {
    if (fov_min_cd_ < fov_max_cd_) return azimuth_cd >= fov_min_cd_ && azimuth_cd <= fov_max_cd_;
    if (fov_min_cd_ > fov_max_cd_) return azimuth_cd <= fov_max_cd_ || azimuth_cd >= fov_min_cd_;
    return false;
  }
  void emit(int laser, const std::uint8_t* ret, float azimuth_f, bool check_point_fov,
            double time, VelodyneReturn type);
  VelodyneReturn returnType(std::uint8_t mode, int block, const std::uint8_t* ret,
                            const std::uint8_t* other) const;
  void decode16(const std::uint8_t* packet, double time, std::uint8_t mode);
  void decode32(const std::uint8_t* packet, double time, std::uint8_t mode);
  void decode128(const std::uint8_t* packet, double time, std::uint8_t mode);
  void fitRotor(const std::uint8_t* packet, std::uint8_t mode);
  double blockStart(int block, bool dual) const;
  /// Azimuth (0.01°) of a firing `offset` seconds into the packet: its block's azimuth plus
  /// the rotor's turn since the block's sequence began.
  float exactAzimuth(const std::uint8_t* packet, int block, bool dual, double offset,
                     int laser) const {
    return static_cast<float>(u16(packet + block * kBlockBytes + 2) +
                              rotor_rate_ * (offset - blockStart(block, dual)) -
                              lasers_[laser].rot_cd);
  }
  bool repairBlocks(std::uint8_t mode, const std::string& where);

  VelodyneOptions options_;
  std::array<std::uint8_t, kVelodyneDataPacketSize> packet_{};  // the packet being decoded, repaired
  bool skip_[kBlocks] = {};  // blocks of packet_ not to decode (repairBlocks)
  std::uint32_t cut_cd_ = 0;
  int fov_min_cd_ = 0, fov_max_cd_ = kCentiDegrees;
  std::optional<VelodyneModel> model_;
  std::string calibration_source_;
  std::uint8_t last_mode_ = 0;
  float distance_resolution_ = 0.002f;
  std::vector<LaserTerms> lasers_;
  DecodedScan scan_;
  std::vector<std::uint16_t> azimuth_cd_;  // per point of scan_, for the cut
  std::deque<DecodedScan> ready_;
  std::size_t packets_in_scan_ = 0;
  std::uint32_t prev_first_phased_ = 0;
  double rotor_rate_ = 0;  // 0.01°/s, measured over the latest packet(s)
  std::int64_t prev_stamp_us_ = -1;  // the previous packet's µs-past-the-hour and first azimuth
  std::uint16_t prev_azimuth_ = 0;
  std::vector<std::uint8_t> held_;  // a first 0x21 packet, until the next says which model
  double held_time_ = 0;
  std::string held_where_;
};

}  // namespace hazmap::velodyne_detail
