#include "hazmap/io/pcd.hpp"

#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "io/io_detail.hpp"
#include "io/point_fields.hpp"

namespace hazmap {

namespace {

using io_detail::Scalar;

struct PcdField {
  std::string name;
  std::size_t size = 4;
  char type = 'F';
  std::size_t count = 1;
  Scalar scalar = Scalar::F32;
  std::size_t offset = 0;        ///< byte offset inside a binary record
  std::size_t token_index = 0;   ///< index of its first value on an ascii line
};

struct PcdHeader {
  std::vector<PcdField> fields;
  std::uint64_t width = 0, height = 1, points = 0;
  bool has_width = false, has_points = false;
  std::string data;
  std::size_t data_offset = 0;   ///< first byte after the DATA line
  std::size_t data_line = 0;     ///< line number of the DATA line
  std::size_t point_size = 0;    ///< bytes per binary record
  std::size_t tokens = 0;        ///< values per ascii line
  bool hazmap_classes = false;   ///< written by hazmap: label holds class ids
};

constexpr const char* kHazmapMarker = "hazmap: label holds hazmap class ids";

std::optional<Scalar> scalarOf(char type, std::size_t size) {
  switch (type) {
    case 'F':
      if (size == 4) return Scalar::F32;
      if (size == 8) return Scalar::F64;
      return std::nullopt;
    case 'I':
      if (size == 1) return Scalar::I8;
      if (size == 2) return Scalar::I16;
      if (size == 4) return Scalar::I32;
      if (size == 8) return Scalar::I64;
      return std::nullopt;
    case 'U':
      if (size == 1) return Scalar::U8;
      if (size == 2) return Scalar::U16;
      if (size == 4) return Scalar::U32;
      if (size == 8) return Scalar::U64;
      return std::nullopt;
  }
  return std::nullopt;
}

/// The header's per-field lines as written, before they are checked against FIELDS.
struct HeaderLines {
  std::vector<std::string_view> sizes, types, counts;
  bool have_sizes = false, have_types = false, have_counts = false, have_fields = false;
  bool done = false;   ///< the DATA line was reached
};

/// Applies one header entry (first token `tok[0]`, on line `ln`) to `h` and `raw`.
void readHeaderEntry(const std::vector<std::string_view>& tok, std::size_t ln, const io_detail::LineReader& lines,
                     const std::filesystem::path& path, PcdHeader& h, HeaderLines& raw) {
  const std::string key = io_detail::toLower(tok[0]);
  const auto one_uint = [&](const char* name) -> std::uint64_t {
    std::uint64_t v;
    if (tok.size() != 2 || !io_detail::parseUint64(tok[1], v))
      io_detail::failAtLine(path, ln, std::string(name) + " needs one non-negative integer");
    return v;
  };
  if (key == "version") {
    return;
  } else if (key == "fields" || key == "columns") {
    if (tok.size() < 2) io_detail::failAtLine(path, ln, "FIELDS lists no field");
    h.fields.clear();
    for (std::size_t k = 1; k < tok.size(); ++k) h.fields.push_back({std::string(tok[k])});
    raw.have_fields = true;
  } else if (key == "size") {
    raw.sizes.assign(tok.begin() + 1, tok.end());
    raw.have_sizes = true;
  } else if (key == "type") {
    raw.types.assign(tok.begin() + 1, tok.end());
    raw.have_types = true;
  } else if (key == "count") {
    raw.counts.assign(tok.begin() + 1, tok.end());
    raw.have_counts = true;
  } else if (key == "width") {
    h.width = one_uint("WIDTH");
    h.has_width = true;
  } else if (key == "height") {
    h.height = one_uint("HEIGHT");
  } else if (key == "points") {
    h.points = one_uint("POINTS");
    h.has_points = true;
  } else if (key == "viewpoint") {
    return;
  } else if (key == "data") {
    if (tok.size() != 2) io_detail::failAtLine(path, ln, "DATA needs one kind (ascii, binary or binary_compressed)");
    h.data = io_detail::toLower(tok[1]);
    h.data_offset = lines.offset();
    h.data_line = ln;
    raw.done = true;
  } else {
    std::string shown(tok[0].substr(0, 30));
    io_detail::failAtLine(path, ln, "unknown header entry '" + shown + "' (not a PCD file?)");
  }
}

/// Reads the header lines up to and including DATA (comments may carry the hazmap marker).
HeaderLines readHeaderLines(std::string_view text, const std::filesystem::path& path, PcdHeader& h) {
  HeaderLines raw;
  io_detail::LineReader lines(text);
  std::string_view line;
  std::vector<std::string_view> tok;
  while (!raw.done && lines.next(line)) {
    const auto trimmed = io_detail::trim(line);
    if (trimmed.empty()) continue;
    if (trimmed.front() == '#') {
      if (trimmed.find(kHazmapMarker) != std::string_view::npos) h.hazmap_classes = true;
      continue;
    }
    io_detail::splitTokens(trimmed, tok);
    readHeaderEntry(tok, lines.lineNumber(), lines, path, h, raw);
  }
  return raw;
}

/// The required lines are there, the DATA kind is known, SIZE/TYPE/COUNT match FIELDS.
void checkHeaderLines(const std::string& where, const PcdHeader& h, const HeaderLines& raw) {
  if (!raw.done) fail(where, "header has no DATA line (truncated or not a PCD file)");
  if (!raw.have_fields) fail(where, "header has no FIELDS line");
  if (h.data != "ascii" && h.data != "binary" && h.data != "binary_compressed")
    fail(where, "bad DATA kind '" + h.data.substr(0, 30) + "' (expected ascii, binary or binary_compressed)");
  const std::size_t nf = h.fields.size();
  const auto check_len = [&](const std::vector<std::string_view>& v, const char* name) {
    if (v.size() != nf)
      fail(where, std::string(name) + " has " + std::to_string(v.size()) + " entries but FIELDS has " +
                      std::to_string(nf));
  };
  if (!raw.have_sizes) fail(where, "header has no SIZE line");
  if (!raw.have_types) fail(where, "header has no TYPE line");
  check_len(raw.sizes, "SIZE");
  check_len(raw.types, "TYPE");
  if (raw.have_counts) check_len(raw.counts, "COUNT");
}

/// Each field's size, type and count, its byte offset in a record and token index on a line.
void layoutFields(const std::string& where, const HeaderLines& raw, PcdHeader& h) {
  std::size_t offset = 0, token = 0;
  for (std::size_t k = 0; k < h.fields.size(); ++k) {
    PcdField& f = h.fields[k];
    const auto& sizes = raw.sizes;
    const auto& types = raw.types;
    std::uint64_t size = 0, count = 1;
    if (!io_detail::parseUint64(sizes[k], size))
      fail(where, "field '" + f.name + "': SIZE '" + std::string(sizes[k].substr(0, 20)) + "' is not an integer");
    if (raw.have_counts && !io_detail::parseUint64(raw.counts[k], count))
      fail(where, "field '" + f.name + "': COUNT '" + std::string(raw.counts[k].substr(0, 20)) + "' is not an integer");
    if (count == 0 || count > (1u << 16))
      fail(where, "field '" + f.name + "': COUNT " + std::to_string(count) + " out of range 1..65536");
    if (types[k].size() != 1 || std::string_view("FIU").find(types[k][0]) == std::string_view::npos)
      fail(where, "field '" + f.name + "': unknown TYPE '" + std::string(types[k].substr(0, 20)) +
                      "' (expected F, I or U)");
    const auto scalar = scalarOf(types[k][0], size);
    if (!scalar)
      fail(where, "field '" + f.name + "': unsupported SIZE " + std::to_string(size) + " for TYPE " +
                      std::string(types[k]));
    f.size = size;
    f.type = types[k][0];
    f.count = count;
    f.scalar = *scalar;
    f.offset = offset;
    f.token_index = token;
    offset += size * count;
    token += count;
  }
  h.point_size = offset;
  h.tokens = token;
}

/// WIDTH, HEIGHT and POINTS agree (either WIDTH or POINTS may be missing).
void resolvePointCount(const std::string& where, PcdHeader& h) {
  if (!h.has_width && !h.has_points) fail(where, "header has neither WIDTH nor POINTS");
  if (!h.has_width) h.width = h.points, h.height = 1;
  std::uint64_t wh = 0;
  if (__builtin_mul_overflow(h.width, h.height, &wh))
    fail(where, "WIDTH × HEIGHT overflows");
  if (!h.has_points) h.points = wh;
  if (h.points != wh)
    fail(where, "POINTS " + std::to_string(h.points) + " differs from WIDTH × HEIGHT = " + std::to_string(wh));
}

PcdHeader parseHeader(std::string_view text, const std::filesystem::path& path) {
  const std::string where = path.string();
  PcdHeader h;
  const HeaderLines raw = readHeaderLines(text, path, h);
  checkHeaderLines(where, h, raw);
  layoutFields(where, raw, h);
  resolvePointCount(where, h);
  return h;
}

/// Where each channel lives: base pointer + stride per point (binary and binary_compressed).
struct Column {
  const char* base = nullptr;
  std::size_t stride = 0;
  Scalar type = Scalar::F32;
  double at(std::size_t i) const { return io_detail::loadScalar(base + i * stride, type); }
};

/// The fields feeding each channel (x, y, z required; the others may be null).
struct PcdChannels {
  const PcdField *x, *y, *z, *intensity, *label, *time, *property;
};

PcdChannels findChannels(const std::string& where, const PcdHeader& h) {
  const auto find = [&](const auto& names) { return io_fields::findField(h.fields, names); };
  const PcdField* fx = find(std::array{"x"});
  const PcdField* fy = find(std::array{"y"});
  const PcdField* fz = find(std::array{"z"});
  if (!fx) fail(where, "missing field 'x'");
  if (!fy) fail(where, "missing field 'y'");
  if (!fz) fail(where, "missing field 'z'");
  return {fx, fy, fz, find(io_fields::kIntensityNames), find(io_fields::kLabelNames), find(io_fields::kTimeNames),
          find(io_fields::kPropertyNames)};
}

void readAsciiPoints(const io_detail::FileBytes& bytes, const PcdHeader& h, const std::filesystem::path& path,
                     const PcdChannels& ch, io_fields::ChannelSink& sink) {
  const std::string where = path.string();
  const std::size_t remaining = bytes.size - h.data_offset;
  const std::uint64_t n = h.points;
  // Every point needs at least one character plus a separator per value.
  if (n > 0 && (n > remaining || n * h.tokens * 2 - 1 > remaining))
    fail(where, "truncated: header claims " + std::to_string(n) + " points but only " +
                    std::to_string(remaining) + " bytes of data follow");
  sink.reserve(n);
  io_detail::LineReader lines(bytes.view().substr(h.data_offset), h.data_line + 1);
  std::string_view line;
  std::vector<std::string_view> tok;
  std::uint64_t read = 0;
  while (lines.next(line)) {
    io_detail::splitTokens(line, tok);
    if (tok.empty()) continue;
    const std::size_t ln = lines.lineNumber();
    if (read == n) io_detail::failAtLine(path, ln, "more points than POINTS " + std::to_string(n));
    if (tok.size() != h.tokens)
      io_detail::failAtLine(path, ln, "expected " + std::to_string(h.tokens) + " values, found " +
                                          std::to_string(tok.size()));
    const auto val = [&](const PcdField* f) {
      return f ? io_detail::numberAt(tok[f->token_index], path, ln) : 0.0;
    };
    sink.add(val(ch.x), val(ch.y), val(ch.z), val(ch.intensity), val(ch.label), val(ch.time), val(ch.property),
             read);
    ++read;
  }
  if (read != n)
    fail(where, "truncated: expected " + std::to_string(n) + " points, found " + std::to_string(read));
}

/// One Column per channel, in PcdChannels order.
struct Columns {
  Column x, y, z, intensity, label, time, property;
};

/// Sets each present channel's column with `column(field, c)`.
template <typename Fn>
Columns makeColumns(const PcdChannels& ch, Fn column) {
  Columns c;
  for (auto [f, col] : {std::pair{ch.x, &c.x}, {ch.y, &c.y}, {ch.z, &c.z}, {ch.intensity, &c.intensity},
                        {ch.label, &c.label}, {ch.time, &c.time}, {ch.property, &c.property}})
    if (f) column(f, *col);
  return c;
}

/// binary: records of point_size bytes, fields interleaved.
Columns binaryColumns(const std::string& where, const char* data, std::size_t remaining, const PcdHeader& h,
                      const PcdChannels& ch) {
  const std::uint64_t n = h.points;
  if (n > remaining / h.point_size)
    fail(where, "truncated: header claims " + std::to_string(n) + " points of " +
                    std::to_string(h.point_size) + " bytes but only " + std::to_string(remaining) +
                    " bytes of data follow");
  return makeColumns(ch, [&](const PcdField* f, Column& c) { c = {data + f->offset, h.point_size, f->scalar}; });
}

/// binary_compressed: u32 compressed size, u32 raw size, LZF block of SoA fields, unpacked into
/// `unpacked`.
Columns compressedColumns(const std::string& where, const char* data, std::size_t remaining, const PcdHeader& h,
                          const PcdChannels& ch, std::unique_ptr<char[]>& unpacked) {
  const std::uint64_t n = h.points;
  if (remaining < 8) fail(where, "truncated: binary_compressed data has no size words");
  std::uint32_t comp = 0, raw = 0;
  std::memcpy(&comp, data, 4);
  std::memcpy(&raw, data + 4, 4);
  if (comp > remaining - 8)
    fail(where, "truncated: compressed block of " + std::to_string(comp) + " bytes but only " +
                    std::to_string(remaining - 8) + " bytes follow");
  if (n > std::numeric_limits<std::uint64_t>::max() / h.point_size || n * h.point_size != raw)
    fail(where, "compressed block unpacks to " + std::to_string(raw) + " bytes but " +
                    std::to_string(n) + " points of " + std::to_string(h.point_size) + " bytes need " +
                    (n > std::numeric_limits<std::uint32_t>::max() ? std::string("more")
                                                                    : std::to_string(n * h.point_size)));
  // LZF expands at most ~88× (264 bytes from a 3-byte back-reference): refuse absurd claims
  // before allocating.
  if (raw > std::uint64_t(comp) * 90 + 64)
    fail(where, "compressed block claims " + std::to_string(raw) + " bytes from only " +
                    std::to_string(comp) + " compressed bytes (corrupt)");
  unpacked = std::make_unique_for_overwrite<char[]>(raw + 1);
  if (raw > 0 && io_detail::lzfDecompress(data + 8, comp, unpacked.get(), raw) != raw)
    fail(where, "corrupt binary_compressed data (LZF decompression failed)");
  // Fields are stored one after the other, each as n values of size*count bytes.
  std::vector<std::size_t> block(h.fields.size());
  std::size_t off = 0;
  for (std::size_t k = 0; k < h.fields.size(); ++k) {
    block[k] = off;
    off += h.fields[k].size * h.fields[k].count * n;
  }
  return makeColumns(ch, [&](const PcdField* f, Column& c) {
    const std::size_t k = static_cast<std::size_t>(f - h.fields.data());
    c = {unpacked.get() + block[k], f->size * f->count, f->scalar};
  });
}

void readBinaryPoints(const io_detail::FileBytes& bytes, const PcdHeader& h, const std::string& where,
                      const PcdChannels& ch, io_fields::ChannelSink& sink) {
  const std::size_t remaining = bytes.size - h.data_offset;
  const std::uint64_t n = h.points;
  const char* data = bytes.begin() + h.data_offset;
  std::unique_ptr<char[]> unpacked;
  const Columns c = h.data == "binary" ? binaryColumns(where, data, remaining, h, ch)
                                       : compressedColumns(where, data, remaining, h, ch, unpacked);
  sink.reserve(n);
  if (!ch.intensity && !ch.label && !ch.time && !ch.property) {
    for (std::size_t i = 0; i < n; ++i) sink.addXyz(c.x.at(i), c.y.at(i), c.z.at(i));
  } else {
    for (std::size_t i = 0; i < n; ++i)
      sink.add(c.x.at(i), c.y.at(i), c.z.at(i), ch.intensity ? c.intensity.at(i) : 0.0,
               ch.label ? c.label.at(i) : 0.0, ch.time ? c.time.at(i) : 0.0,
               ch.property ? c.property.at(i) : 0.0, i);
  }
}

}  // namespace

LabeledCloud readPcd(const std::filesystem::path& path, const ClassTable& table, ReadStats* stats) {
  const std::string where = path.string();
  const io_detail::FileBytes bytes = io_detail::readFileBytes(path);
  const PcdHeader h = parseHeader(bytes.view(), path);
  const PcdChannels ch = findChannels(where, h);
  io_fields::ChannelSink sink(where, table, h.hazmap_classes, ch.intensity, ch.label, ch.time, ch.property);
  if (h.data == "ascii")
    readAsciiPoints(bytes, h, path, ch, sink);
  else
    readBinaryPoints(bytes, h, where, ch, sink);
  if (stats) {
    stats->format = "pcd " + h.data;
    stats->fields.clear();
    for (const auto& f : h.fields) stats->fields.push_back(f.name);
  }
  return sink.finish(h.points, stats);
}

namespace {

/// Which optional channels a written file carries (label is always written).
struct WrittenChannels {
  bool intensity, time, property;
  explicit WrittenChannels(const LabeledCloud& cloud)
      : intensity(!cloud.intensity.empty()), time(!cloud.timestamps.empty()), property(!cloud.property.empty()) {}
  std::size_t recordBytes() const { return 12 + (intensity ? 4 : 0) + 4 + (time ? 8 : 0) + (property ? 4 : 0); }
};

std::string headerText(std::size_t n, WrittenChannels has, PcdEncoding encoding) {
  std::string fields = "x y z", sizes = "4 4 4", types = "F F F", counts = "1 1 1";
  const auto addField = [&](const char* name, const char* size, const char* type) {
    fields += std::string(" ") + name;
    sizes += std::string(" ") + size;
    types += std::string(" ") + type;
    counts += " 1";
  };
  if (has.intensity) addField("intensity", "4", "F");
  addField("label", "4", "U");
  if (has.time) addField("timestamp", "8", "F");
  if (has.property) addField("property", "4", "F");
  const char* kind = encoding == PcdEncoding::Ascii    ? "ascii"
                     : encoding == PcdEncoding::Binary ? "binary"
                                                       : "binary_compressed";
  std::string out;
  out += "# .PCD v0.7 - Point Cloud Data file format\n";
  out += std::string("# ") + kHazmapMarker + "\n";
  out += "VERSION 0.7\nFIELDS " + fields + "\nSIZE " + sizes + "\nTYPE " + types + "\nCOUNT " + counts +
         "\nWIDTH " + std::to_string(n) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " +
         std::to_string(n) + "\nDATA " + kind + "\n";
  return out;
}

void appendAscii(std::string& out, const LabeledCloud& cloud, WrittenChannels has) {
  const std::size_t n = cloud.size();
  out.reserve(out.size() + n * 40);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& p = cloud.points[i];
    io_detail::appendNumber(out, p.x());
    out += ' ';
    io_detail::appendNumber(out, p.y());
    out += ' ';
    io_detail::appendNumber(out, p.z());
    if (has.intensity) out += ' ', io_detail::appendNumber(out, cloud.intensity[i]);
    out += ' ';
    io_detail::appendNumber(out, std::uint64_t{cloud.classes[i]});
    if (has.time) out += ' ', io_detail::appendNumber(out, cloud.timestamps[i]);
    if (has.property) out += ' ', io_detail::appendNumber(out, cloud.property[i]);
    out += '\n';
  }
}

void appendBinary(std::string& out, const LabeledCloud& cloud, WrittenChannels has) {
  const std::size_t n = cloud.size(), rec = has.recordBytes();
  const std::size_t head = out.size();
  out.resize(head + n * rec);
  char* dst = out.data() + head;
  for (std::size_t i = 0; i < n; ++i) {
    char* r = dst + i * rec;
    std::memcpy(r, cloud.points[i].data(), 12);
    r += 12;
    if (has.intensity) std::memcpy(r, &cloud.intensity[i], 4), r += 4;
    const std::uint32_t label = cloud.classes[i];
    std::memcpy(r, &label, 4);
    r += 4;
    if (has.time) std::memcpy(r, &cloud.timestamps[i], 8), r += 8;
    if (has.property) std::memcpy(r, &cloud.property[i], 4);
  }
}

/// Structure of arrays, field after field, then LZF behind the two u32 size words.
void appendCompressed(std::string& out, const LabeledCloud& cloud, WrittenChannels has,
                      const std::filesystem::path& path) {
  const std::size_t n = cloud.size();
  std::string raw(n * has.recordBytes(), '\0');
  char* dst = raw.data();
  const auto put = [&](const void* src, std::size_t bytes) {
    std::memcpy(dst, src, bytes);
    dst += bytes;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (std::size_t i = 0; i < n; ++i) put(&cloud.points[i][axis], 4);
  if (has.intensity) put(cloud.intensity.data(), 4 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t label = cloud.classes[i];
    put(&label, 4);
  }
  if (has.time) put(cloud.timestamps.data(), 8 * n);
  if (has.property) put(cloud.property.data(), 4 * n);
  const std::string comp = io_detail::lzfCompress(raw.data(), raw.size());
  if (raw.size() > std::numeric_limits<std::uint32_t>::max() ||
      comp.size() > std::numeric_limits<std::uint32_t>::max())
    fail(path.string(), "cloud too large for binary_compressed (4 GiB limit)");
  const std::uint32_t sizes2[2] = {static_cast<std::uint32_t>(comp.size()),
                                   static_cast<std::uint32_t>(raw.size())};
  out.append(reinterpret_cast<const char*>(sizes2), 8);
  out += comp;
}

}  // namespace

void writePcd(const std::filesystem::path& path, const LabeledCloud& cloud, PcdEncoding encoding) {
  cloud.checkConsistent(path.string());
  const WrittenChannels has(cloud);
  std::string out = headerText(cloud.size(), has, encoding);
  if (encoding == PcdEncoding::Ascii)
    appendAscii(out, cloud, has);
  else if (encoding == PcdEncoding::Binary)
    appendBinary(out, cloud, has);
  else
    appendCompressed(out, cloud, has, path);
  writeTextAtomically(path, out);
}

}  // namespace hazmap
