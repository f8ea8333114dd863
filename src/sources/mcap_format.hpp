#pragma once
// MCAP records (https://mcap.dev/spec): magic, then records of <opcode u8><length u64><body>;
// little-endian integers, strings as <u32 length><bytes>, byte arrays with a u32 or u64
// length, maps as <u32 byte length><entries>.
#include <cstdint>

namespace hazmap::sources::mcap {

enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

inline constexpr std::uint64_t kRecordPrefix = 1 + 8;          // opcode + length
inline constexpr std::uint64_t kFooterBody = 8 + 8 + 4;        // summary_start, summary_offset_start, crc
inline constexpr std::uint64_t kMagicSize = 8;
inline constexpr std::uint64_t kMessagePrefix = 2 + 4 + 8 + 8;  // channel, sequence, log, publish

}  // namespace hazmap::sources::mcap
