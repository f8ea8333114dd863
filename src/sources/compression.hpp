#pragma once
// Decompressors of the chunk formats bags use: zstd and LZ4 frames (MCAP), bz2 and roslz4
// (ROS 1; roslz4 is the LZ4 frame format). Each checks the size it produces against the size
// the container recorded and throws hazmap::Error("<where>: <what>") otherwise.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace hazmap::sources {

/// Largest chunk a bag may declare: a corrupt size must not allocate the machine away.
inline constexpr std::uint64_t kMaxChunkBytes = std::uint64_t{1} << 30;

enum class Codec { None, Zstd, Lz4Frame, Bz2 };

/// Decompresses into out[0, size); `out` grows when too small (never shrinks, so a reused
/// buffer is not cleared per chunk).
void decompress(Codec codec, std::span<const std::uint8_t> in, std::uint64_t size,
                std::vector<std::uint8_t>& out, const std::string& where);

/// zstd (level) / LZ4 frame compression, for the writers and the tests.
std::vector<std::uint8_t> compressZstd(std::span<const std::uint8_t> in, int level);
std::vector<std::uint8_t> compressLz4Frame(std::span<const std::uint8_t> in);
std::vector<std::uint8_t> compressBz2(std::span<const std::uint8_t> in);

/// CRC-32 (ISO-HDLC, zlib's), as MCAP uses.
std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t crc = 0);

}  // namespace hazmap::sources
