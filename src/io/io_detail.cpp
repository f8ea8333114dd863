#include "io/io_detail.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>

#include "hazmap/core/error.hpp"

namespace hazmap::io_detail {

FileBytes readFileBytes(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    fail(path.string(), err == ENOENT ? "file not found" : std::string("cannot open: ") + std::strerror(err));
  }
  struct FdCloser {
    int fd;
    ~FdCloser() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) fail(path.string(), "cannot stat");
  if (S_ISDIR(st.st_mode)) fail(path.string(), "is a directory, not a file");
  if (!S_ISREG(st.st_mode)) fail(path.string(), "is not a regular file");
  FileBytes f;
  f.size = static_cast<std::size_t>(st.st_size);
  f.data = std::make_unique_for_overwrite<char[]>(f.size + 1);
  std::size_t got = 0;
  while (got < f.size) {
    const ssize_t r = ::read(fd, f.data.get() + got, f.size - got);
    if (r < 0) {
      if (errno == EINTR) continue;
      fail(path.string(), std::string("read error: ") + std::strerror(errno));
    }
    if (r == 0) break;  // file shrank while reading
    got += static_cast<std::size_t>(r);
  }
  f.size = got;
  f.data[got] = '\0';
  return f;
}

bool LineReader::next(std::string_view& line) {
  if (pos_ >= text_.size()) return false;
  const std::size_t end = text_.find('\n', pos_);
  std::size_t stop = end == std::string_view::npos ? text_.size() : end;
  line = text_.substr(pos_, stop - pos_);
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  pos_ = end == std::string_view::npos ? text_.size() : end + 1;
  ++next_line_;
  return true;
}

void splitTokens(std::string_view line, std::vector<std::string_view>& out) {
  out.clear();
  std::size_t i = 0;
  const std::size_t n = line.size();
  while (i < n) {
    while (i < n && isBlank(line[i])) ++i;
    if (i >= n) break;
    std::size_t j = i;
    while (j < n && !isBlank(line[j])) ++j;
    out.push_back(line.substr(i, j - i));
    i = j;
  }
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && isBlank(s.front())) s.remove_prefix(1);
  while (!s.empty() && isBlank(s.back())) s.remove_suffix(1);
  return s;
}

bool parseDouble(std::string_view token, double& out) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), out);
  if (ec == std::errc::result_out_of_range) {
    // Overflow reads as ±inf (dropped later as non-finite); underflow as 0.
    double probe = 0;
    std::string copy(token);
    probe = std::strtod(copy.c_str(), nullptr);
    out = probe;
    return true;
  }
  return ec == std::errc() && ptr == token.data() + token.size();
}

bool parseUint64(std::string_view token, std::uint64_t& out) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), out);
  return ec == std::errc() && ptr == token.data() + token.size();
}

void failAtLine(const std::filesystem::path& path, std::size_t line, const std::string& what) {
  fail(path.string(), "line " + std::to_string(line) + ": " + what);
}

double numberAt(std::string_view token, const std::filesystem::path& path, std::size_t line) {
  double v;
  if (!parseDouble(token, v)) {
    std::string shown(token.substr(0, 40));
    for (char& c : shown)
      if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) c = '?';
    failAtLine(path, line, "'" + shown + "' is not a number");
  }
  return v;
}

std::string toLower(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return out;
}

std::string extensionOf(const std::filesystem::path& path) { return toLower(path.extension().string()); }

// ---- LZF ---------------------------------------------------------------------------------------
// Format (liblzf): a control byte c. c < 32: a literal run of c+1 bytes follows. Otherwise a
// back-reference: length L = c >> 5 (7 means "add the next byte"), offset = ((c & 31) << 8) +
// next byte; copy L+2 bytes starting offset+1 bytes back in the output (may overlap).

std::size_t lzfDecompress(const char* in_c, std::size_t in_len, char* out_c, std::size_t out_len) {
  const auto* in = reinterpret_cast<const unsigned char*>(in_c);
  auto* out = reinterpret_cast<unsigned char*>(out_c);
  const unsigned char* ip = in;
  const unsigned char* const in_end = in + in_len;
  unsigned char* op = out;
  unsigned char* const out_end = out + out_len;
  while (ip < in_end) {
    unsigned ctrl = *ip++;
    if (ctrl < 32) {
      const std::size_t len = ctrl + 1;
      if (static_cast<std::size_t>(out_end - op) < len) return 0;
      if (static_cast<std::size_t>(in_end - ip) < len) return 0;
      std::memcpy(op, ip, len);
      op += len;
      ip += len;
    } else {
      std::size_t len = ctrl >> 5;
      if (len == 7) {
        if (ip >= in_end) return 0;
        len += *ip++;
      }
      if (ip >= in_end) return 0;
      const std::size_t back = ((ctrl & 0x1f) << 8) + *ip++ + 1;
      len += 2;
      if (static_cast<std::size_t>(op - out) < back) return 0;
      if (static_cast<std::size_t>(out_end - op) < len) return 0;
      const unsigned char* ref = op - back;
      for (std::size_t k = 0; k < len; ++k) op[k] = ref[k];  // overlapping copy, byte by byte
      op += len;
    }
  }
  return static_cast<std::size_t>(op - out);
}

std::string lzfCompress(const char* in_c, std::size_t n) {
  const auto* in = reinterpret_cast<const unsigned char*>(in_c);
  constexpr std::size_t kMaxOffset = 1u << 13;   // 8192
  constexpr std::size_t kMaxLen = 264;           // 7 + 255 + 2
  constexpr unsigned kHashBits = 14;
  std::vector<std::size_t> table(std::size_t{1} << kHashBits, static_cast<std::size_t>(-1));
  std::string out;
  out.reserve(n + n / 32 + 16);
  std::size_t lit_start = 0;  // start of the pending literal run
  const auto flushLiterals = [&](std::size_t end) {
    while (lit_start < end) {
      const std::size_t len = std::min<std::size_t>(32, end - lit_start);
      out.push_back(static_cast<char>(len - 1));
      out.append(reinterpret_cast<const char*>(in + lit_start), len);
      lit_start += len;
    }
  };
  std::size_t i = 0;
  while (i + 2 < n) {
    const std::uint32_t v = (std::uint32_t(in[i]) << 16) | (std::uint32_t(in[i + 1]) << 8) | in[i + 2];
    const std::size_t h = ((v * 2654435761u) >> (32 - kHashBits)) & ((1u << kHashBits) - 1);
    const std::size_t cand = table[h];
    table[h] = i;
    if (cand != static_cast<std::size_t>(-1) && i - cand <= kMaxOffset && i > cand &&
        in[cand] == in[i] && in[cand + 1] == in[i + 1] && in[cand + 2] == in[i + 2]) {
      std::size_t len = 3;
      const std::size_t limit = std::min(kMaxLen, n - i);
      while (len < limit && in[cand + len] == in[i + len]) ++len;
      flushLiterals(i);
      const std::size_t off = i - cand - 1;
      const std::size_t l = len - 2;
      if (l < 7) {
        out.push_back(static_cast<char>((l << 5) | (off >> 8)));
      } else {
        out.push_back(static_cast<char>((7 << 5) | (off >> 8)));
        out.push_back(static_cast<char>(l - 7));
      }
      out.push_back(static_cast<char>(off & 0xff));
      i += len;
      lit_start = i;
    } else {
      ++i;
    }
  }
  flushLiterals(n);
  return out;
}

void appendNumber(std::string& out, double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

void appendNumber(std::string& out, float v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

void appendNumber(std::string& out, std::uint64_t v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

}  // namespace hazmap::io_detail
