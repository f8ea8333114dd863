#include "compression.hpp"

#include <bzlib.h>
#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <limits>
#include <memory>

#include "hazmap/core/error.hpp"

namespace hazmap::sources {
namespace {

void decompressZstd(std::span<const std::uint8_t> in, std::uint64_t size, std::uint8_t* out,
                    const std::string& where) {
  const unsigned long long declared = ZSTD_getFrameContentSize(in.data(), in.size());
  if (declared == ZSTD_CONTENTSIZE_ERROR) fail(where, "not a zstd frame");
  if (declared != ZSTD_CONTENTSIZE_UNKNOWN && declared != size)
    fail(where, "zstd frame holds " + std::to_string(declared) + " bytes, the container says " + std::to_string(size));
  const std::size_t got = ZSTD_decompress(out, size, in.data(), in.size());
  if (ZSTD_isError(got)) fail(where, std::string("zstd: ") + ZSTD_getErrorName(got));
  if (got != size) fail(where, "zstd gave " + std::to_string(got) + " bytes, expected " + std::to_string(size));
}

void decompressLz4(std::span<const std::uint8_t> in, std::uint64_t size, std::uint8_t* out,
                   const std::string& where) {
  LZ4F_dctx* raw = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) fail(where, "lz4: no context");
  std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> ctx(raw, LZ4F_freeDecompressionContext);
  std::size_t in_pos = 0, out_pos = 0;
  while (in_pos < in.size()) {
    std::size_t in_n = in.size() - in_pos, out_n = size - out_pos;
    const std::size_t hint = LZ4F_decompress(ctx.get(), out + out_pos, &out_n, in.data() + in_pos, &in_n, nullptr);
    if (LZ4F_isError(hint)) fail(where, std::string("lz4: ") + LZ4F_getErrorName(hint));
    in_pos += in_n;
    out_pos += out_n;
    if (hint == 0) {
      // End of a frame; roslz4 may concatenate frames, so keep going while input remains.
      LZ4F_resetDecompressionContext(ctx.get());
      continue;
    }
    if (in_n == 0 && out_n == 0) fail(where, "lz4: output larger than the recorded size " + std::to_string(size));
  }
  if (out_pos != size) fail(where, "lz4 gave " + std::to_string(out_pos) + " bytes, expected " + std::to_string(size));
}

void decompressBz2(std::span<const std::uint8_t> in, std::uint64_t size, std::uint8_t* out,
                   const std::string& where) {
  if (in.size() > std::numeric_limits<unsigned>::max() || size > std::numeric_limits<unsigned>::max())
    fail(where, "bz2 chunk too large");
  auto out_n = static_cast<unsigned>(size);
  int rc = BZ2_bzBuffToBuffDecompress(reinterpret_cast<char*>(out), &out_n,
                                      const_cast<char*>(reinterpret_cast<const char*>(in.data())),
                                      static_cast<unsigned>(in.size()), 0, 0);
  if (rc == BZ_OUTBUFF_FULL) fail(where, "bz2: output larger than the recorded size " + std::to_string(size));
  if (rc != BZ_OK) fail(where, "bz2: corrupt data (error " + std::to_string(rc) + ")");
  if (out_n != size) fail(where, "bz2 gave " + std::to_string(out_n) + " bytes, expected " + std::to_string(size));
}

}  // namespace

void decompress(Codec codec, std::span<const std::uint8_t> in, std::uint64_t size,
                std::vector<std::uint8_t>& out, const std::string& where) {
  if (size > kMaxChunkBytes) fail(where, "chunk declares " + std::to_string(size) + " bytes (corrupt size?)");
  if (codec == Codec::Lz4Frame && size > 255 * static_cast<std::uint64_t>(in.size()) + 64)
    fail(where, "lz4 chunk of " + std::to_string(in.size()) + " bytes cannot hold " + std::to_string(size));
  if (out.size() < size) out.resize(static_cast<std::size_t>(size));
  switch (codec) {
    case Codec::None:
      if (in.size() != size) fail(where, "uncompressed chunk of " + std::to_string(in.size()) + " bytes, expected " + std::to_string(size));
      std::copy(in.begin(), in.end(), out.begin());
      return;
    case Codec::Zstd: return decompressZstd(in, size, out.data(), where);
    case Codec::Lz4Frame: return decompressLz4(in, size, out.data(), where);
    case Codec::Bz2: return decompressBz2(in, size, out.data(), where);
  }
}

std::vector<std::uint8_t> compressZstd(std::span<const std::uint8_t> in, int level) {
  std::vector<std::uint8_t> out(ZSTD_compressBound(in.size()));
  const std::size_t n = ZSTD_compress(out.data(), out.size(), in.data(), in.size(), level);
  if (ZSTD_isError(n)) fail("zstd", ZSTD_getErrorName(n));
  out.resize(n);
  return out;
}

std::vector<std::uint8_t> compressLz4Frame(std::span<const std::uint8_t> in) {
  LZ4F_preferences_t prefs{};
  prefs.frameInfo.contentSize = in.size();
  std::vector<std::uint8_t> out(LZ4F_compressFrameBound(in.size(), &prefs));
  const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), in.data(), in.size(), &prefs);
  if (LZ4F_isError(n)) fail("lz4", LZ4F_getErrorName(n));
  out.resize(n);
  return out;
}

std::vector<std::uint8_t> compressBz2(std::span<const std::uint8_t> in) {
  auto n = static_cast<unsigned>(in.size() + in.size() / 100 + 600);
  std::vector<std::uint8_t> out(n);
  const int rc = BZ2_bzBuffToBuffCompress(reinterpret_cast<char*>(out.data()), &n,
                                          const_cast<char*>(reinterpret_cast<const char*>(in.data())),
                                          static_cast<unsigned>(in.size()), 9, 0, 0);
  if (rc != BZ_OK) fail("bz2", "compression failed (" + std::to_string(rc) + ")");
  out.resize(n);
  return out;
}

std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t crc) {
  // zlib takes uInt lengths: feed large spans in pieces.
  while (!bytes.empty()) {
    const std::size_t n = std::min<std::size_t>(bytes.size(), 1u << 30);
    crc = static_cast<std::uint32_t>(::crc32(crc, bytes.data(), static_cast<uInt>(n)));
    bytes = bytes.subspan(n);
  }
  return crc;
}

}  // namespace hazmap::sources
