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

PcdHeader parseHeader(std::string_view text, const std::filesystem::path& path) {
  const std::string where = path.string();
  PcdHeader h;
  io_detail::LineReader lines(text);
  std::string_view line;
  std::vector<std::string_view> tok;
  std::vector<std::string_view> sizes, types, counts;
  bool have_sizes = false, have_types = false, have_counts = false, have_fields = false;
  bool done = false;
  while (lines.next(line)) {
    const std::size_t ln = lines.lineNumber();
    const auto trimmed = io_detail::trim(line);
    if (trimmed.empty()) continue;
    if (trimmed.front() == '#') {
      if (trimmed.find(kHazmapMarker) != std::string_view::npos) h.hazmap_classes = true;
      continue;
    }
    io_detail::splitTokens(trimmed, tok);
    const std::string key = io_detail::toLower(tok[0]);
    const auto one_uint = [&](const char* name) -> std::uint64_t {
      std::uint64_t v;
      if (tok.size() != 2 || !io_detail::parseUint64(tok[1], v))
        io_detail::failAtLine(path, ln, std::string(name) + " needs one non-negative integer");
      return v;
    };
    if (key == "version") {
      continue;
    } else if (key == "fields" || key == "columns") {
      if (tok.size() < 2) io_detail::failAtLine(path, ln, "FIELDS lists no field");
      h.fields.clear();
      for (std::size_t k = 1; k < tok.size(); ++k) h.fields.push_back({std::string(tok[k])});
      have_fields = true;
    } else if (key == "size") {
      sizes.assign(tok.begin() + 1, tok.end());
      have_sizes = true;
    } else if (key == "type") {
      types.assign(tok.begin() + 1, tok.end());
      have_types = true;
    } else if (key == "count") {
      counts.assign(tok.begin() + 1, tok.end());
      have_counts = true;
    } else if (key == "width") {
      h.width = one_uint("WIDTH");
      h.has_width = true;
    } else if (key == "height") {
      h.height = one_uint("HEIGHT");
    } else if (key == "points") {
      h.points = one_uint("POINTS");
      h.has_points = true;
    } else if (key == "viewpoint") {
      continue;
    } else if (key == "data") {
      if (tok.size() != 2) io_detail::failAtLine(path, ln, "DATA needs one kind (ascii, binary or binary_compressed)");
      h.data = io_detail::toLower(tok[1]);
      h.data_offset = lines.offset();
      h.data_line = ln;
      done = true;
      break;
    } else {
      std::string shown(tok[0].substr(0, 30));
      io_detail::failAtLine(path, ln, "unknown header entry '" + shown + "' (not a PCD file?)");
    }
  }
  if (!done) fail(where, "header has no DATA line (truncated or not a PCD file)");
  if (!have_fields) fail(where, "header has no FIELDS line");
  if (h.data != "ascii" && h.data != "binary" && h.data != "binary_compressed")
    fail(where, "bad DATA kind '" + h.data.substr(0, 30) + "' (expected ascii, binary or binary_compressed)");
  const std::size_t nf = h.fields.size();
  const auto check_len = [&](const std::vector<std::string_view>& v, const char* name) {
    if (v.size() != nf)
      fail(where, std::string(name) + " has " + std::to_string(v.size()) + " entries but FIELDS has " +
                      std::to_string(nf));
  };
  if (!have_sizes) fail(where, "header has no SIZE line");
  if (!have_types) fail(where, "header has no TYPE line");
  check_len(sizes, "SIZE");
  check_len(types, "TYPE");
  if (have_counts) check_len(counts, "COUNT");
  std::size_t offset = 0, token = 0;
  for (std::size_t k = 0; k < nf; ++k) {
    PcdField& f = h.fields[k];
    std::uint64_t size = 0, count = 1;
    if (!io_detail::parseUint64(sizes[k], size))
      fail(where, "field '" + f.name + "': SIZE '" + std::string(sizes[k].substr(0, 20)) + "' is not an integer");
    if (have_counts && !io_detail::parseUint64(counts[k], count))
      fail(where, "field '" + f.name + "': COUNT '" + std::string(counts[k].substr(0, 20)) + "' is not an integer");
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
  if (!h.has_width && !h.has_points) fail(where, "header has neither WIDTH nor POINTS");
  if (!h.has_width) h.width = h.points, h.height = 1;
  std::uint64_t wh = 0;
  if (__builtin_mul_overflow(h.width, h.height, &wh))
    fail(where, "WIDTH × HEIGHT overflows");
  if (!h.has_points) h.points = wh;
  if (h.points != wh)
    fail(where, "POINTS " + std::to_string(h.points) + " differs from WIDTH × HEIGHT = " + std::to_string(wh));
  return h;
}

/// Where each channel lives: base pointer + stride per point (binary and binary_compressed).
struct Column {
  const char* base = nullptr;
  std::size_t stride = 0;
  Scalar type = Scalar::F32;
  double at(std::size_t i) const { return io_detail::loadScalar(base + i * stride, type); }
};

}  // namespace

LabeledCloud readPcd(const std::filesystem::path& path, const ClassTable& table, ReadStats* stats) {
  const std::string where = path.string();
  const io_detail::FileBytes bytes = io_detail::readFileBytes(path);
  const PcdHeader h = parseHeader(bytes.view(), path);

  // Which field feeds which channel.
  const auto find = [&](const auto& names) { return io_fields::findField(h.fields, names); };
  const PcdField* fx = find(std::array{"x"});
  const PcdField* fy = find(std::array{"y"});
  const PcdField* fz = find(std::array{"z"});
  if (!fx) fail(where, "missing field 'x'");
  if (!fy) fail(where, "missing field 'y'");
  if (!fz) fail(where, "missing field 'z'");
  const PcdField* fi = find(io_fields::kIntensityNames);
  const PcdField* fl = find(io_fields::kLabelNames);
  const PcdField* ft = find(io_fields::kTimeNames);
  const PcdField* fp = find(io_fields::kPropertyNames);

  const std::size_t remaining = bytes.size - h.data_offset;
  const std::uint64_t n = h.points;
  io_fields::ChannelSink sink(where, table, h.hazmap_classes, fi, fl, ft, fp);

  if (h.data == "ascii") {
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
      sink.add(val(fx), val(fy), val(fz), val(fi), val(fl), val(ft), val(fp), read);
      ++read;
    }
    if (read != n)
      fail(where, "truncated: expected " + std::to_string(n) + " points, found " + std::to_string(read));
  } else {
    const char* data = bytes.begin() + h.data_offset;
    std::unique_ptr<char[]> unpacked;
    Column cx, cy, cz, ci, cl, ct, cp;
    const auto binaryColumn = [&](const PcdField* f, Column& c) {
      if (!f) return;
      c = {data + f->offset, h.point_size, f->scalar};
    };
    if (h.data == "binary") {
      if (n > remaining / h.point_size)
        fail(where, "truncated: header claims " + std::to_string(n) + " points of " +
                        std::to_string(h.point_size) + " bytes but only " + std::to_string(remaining) +
                        " bytes of data follow");
      for (auto [f, c] : {std::pair{fx, &cx}, {fy, &cy}, {fz, &cz}, {fi, &ci}, {fl, &cl}, {ft, &ct}, {fp, &cp}})
        binaryColumn(f, *c);
    } else {  // binary_compressed: u32 compressed size, u32 raw size, LZF block of SoA fields
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
      const auto column = [&](const PcdField* f, Column& c) {
        if (!f) return;
        const std::size_t k = static_cast<std::size_t>(f - h.fields.data());
        c = {unpacked.get() + block[k], f->size * f->count, f->scalar};
      };
      for (auto [f, c] : {std::pair{fx, &cx}, {fy, &cy}, {fz, &cz}, {fi, &ci}, {fl, &cl}, {ft, &ct}, {fp, &cp}})
        column(f, *c);
    }
    sink.reserve(n);
    if (!fi && !fl && !ft && !fp) {
      for (std::size_t i = 0; i < n; ++i) sink.addXyz(cx.at(i), cy.at(i), cz.at(i));
    } else {
      for (std::size_t i = 0; i < n; ++i)
        sink.add(cx.at(i), cy.at(i), cz.at(i), fi ? ci.at(i) : 0.0, fl ? cl.at(i) : 0.0,
                 ft ? ct.at(i) : 0.0, fp ? cp.at(i) : 0.0, i);
    }
  }
  if (stats) {
    stats->format = "pcd " + h.data;
    stats->fields.clear();
    for (const auto& f : h.fields) stats->fields.push_back(f.name);
  }
  return sink.finish(n, stats);
}

void writePcd(const std::filesystem::path& path, const LabeledCloud& cloud, PcdEncoding encoding) {
  cloud.checkConsistent(path.string());
  const std::size_t n = cloud.size();
  const bool hi = !cloud.intensity.empty(), ht = !cloud.timestamps.empty(), hp = !cloud.property.empty();
  std::string fields = "x y z", sizes = "4 4 4", types = "F F F", counts = "1 1 1";
  const auto addField = [&](const char* name, const char* size, const char* type) {
    fields += std::string(" ") + name;
    sizes += std::string(" ") + size;
    types += std::string(" ") + type;
    counts += " 1";
  };
  if (hi) addField("intensity", "4", "F");
  addField("label", "4", "U");
  if (ht) addField("timestamp", "8", "F");
  if (hp) addField("property", "4", "F");
  const char* kind = encoding == PcdEncoding::Ascii    ? "ascii"
                     : encoding == PcdEncoding::Binary ? "binary"
                                                       : "binary_compressed";
  std::string out;
  out += "# .PCD v0.7 - Point Cloud Data file format\n";
  out += std::string("# ") + kHazmapMarker + "\n";
  out += "VERSION 0.7\nFIELDS " + fields + "\nSIZE " + sizes + "\nTYPE " + types + "\nCOUNT " + counts +
         "\nWIDTH " + std::to_string(n) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " +
         std::to_string(n) + "\nDATA " + kind + "\n";
  const std::size_t rec = 12 + (hi ? 4 : 0) + 4 + (ht ? 8 : 0) + (hp ? 4 : 0);
  if (encoding == PcdEncoding::Ascii) {
    out.reserve(out.size() + n * 40);
    for (std::size_t i = 0; i < n; ++i) {
      const auto& p = cloud.points[i];
      io_detail::appendNumber(out, p.x());
      out += ' ';
      io_detail::appendNumber(out, p.y());
      out += ' ';
      io_detail::appendNumber(out, p.z());
      if (hi) out += ' ', io_detail::appendNumber(out, cloud.intensity[i]);
      out += ' ';
      io_detail::appendNumber(out, std::uint64_t{cloud.classes[i]});
      if (ht) out += ' ', io_detail::appendNumber(out, cloud.timestamps[i]);
      if (hp) out += ' ', io_detail::appendNumber(out, cloud.property[i]);
      out += '\n';
    }
  } else if (encoding == PcdEncoding::Binary) {
    const std::size_t head = out.size();
    out.resize(head + n * rec);
    char* dst = out.data() + head;
    for (std::size_t i = 0; i < n; ++i) {
      char* r = dst + i * rec;
      std::memcpy(r, cloud.points[i].data(), 12);
      r += 12;
      if (hi) std::memcpy(r, &cloud.intensity[i], 4), r += 4;
      const std::uint32_t label = cloud.classes[i];
      std::memcpy(r, &label, 4);
      r += 4;
      if (ht) std::memcpy(r, &cloud.timestamps[i], 8), r += 8;
      if (hp) std::memcpy(r, &cloud.property[i], 4);
    }
  } else {
    // Structure of arrays, field after field, then LZF.
    std::string raw(n * rec, '\0');
    char* dst = raw.data();
    const auto put = [&](const void* src, std::size_t bytes) {
      std::memcpy(dst, src, bytes);
      dst += bytes;
    };
    for (int axis = 0; axis < 3; ++axis)
      for (std::size_t i = 0; i < n; ++i) put(&cloud.points[i][axis], 4);
    if (hi) put(cloud.intensity.data(), 4 * n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint32_t label = cloud.classes[i];
      put(&label, 4);
    }
    if (ht) put(cloud.timestamps.data(), 8 * n);
    if (hp) put(cloud.property.data(), 4 * n);
    const std::string comp = io_detail::lzfCompress(raw.data(), raw.size());
    if (raw.size() > std::numeric_limits<std::uint32_t>::max() ||
        comp.size() > std::numeric_limits<std::uint32_t>::max())
      fail(path.string(), "cloud too large for binary_compressed (4 GiB limit)");
    const std::uint32_t sizes2[2] = {static_cast<std::uint32_t>(comp.size()),
                                     static_cast<std::uint32_t>(raw.size())};
    out.append(reinterpret_cast<const char*>(sizes2), 8);
    out += comp;
  }
  writeTextAtomically(path, out);
}

}  // namespace hazmap
