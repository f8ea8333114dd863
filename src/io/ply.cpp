#include "hazmap/io/ply.hpp"

#include <algorithm>
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

constexpr const char* kHazmapMarker = "hazmap: label holds hazmap class ids";

enum class PlyFormat { Ascii, BinaryLittleEndian, BinaryBigEndian };

struct PlyProperty {
  std::string name;
  Scalar type = Scalar::F32;
  bool is_list = false;
  Scalar count_type = Scalar::U8;
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> props;
  std::size_t min_item_bytes = 0;  ///< binary size of an item whose lists are all empty
  bool fixed = true;               ///< no list properties
  std::size_t index(std::string_view name_lower) const {
    for (std::size_t k = 0; k < props.size(); ++k)
      if (io_detail::toLower(props[k].name) == name_lower) return k;
    return npos;
  }
  static constexpr std::size_t npos = static_cast<std::size_t>(-1);
};

struct PlyHeader {
  PlyFormat format = PlyFormat::Ascii;
  std::vector<PlyElement> elements;
  std::size_t data_offset = 0;
  std::size_t data_line = 0;
  bool hazmap_classes = false;
};

std::optional<Scalar> plyScalar(std::string_view t) {
  static const std::pair<const char*, Scalar> kTypes[] = {
      {"char", Scalar::I8},     {"int8", Scalar::I8},      {"uchar", Scalar::U8},   {"uint8", Scalar::U8},
      {"short", Scalar::I16},   {"int16", Scalar::I16},    {"ushort", Scalar::U16}, {"uint16", Scalar::U16},
      {"int", Scalar::I32},     {"int32", Scalar::I32},    {"uint", Scalar::U32},   {"uint32", Scalar::U32},
      {"float", Scalar::F32},   {"float32", Scalar::F32},  {"double", Scalar::F64}, {"float64", Scalar::F64}};
  for (const auto& [name, s] : kTypes)
    if (t == name) return s;
  return std::nullopt;
}

PlyHeader parseHeader(std::string_view text, const std::filesystem::path& path) {
  const std::string where = path.string();
  PlyHeader h;
  io_detail::LineReader lines(text);
  std::string_view line;
  std::vector<std::string_view> tok;
  if (!lines.next(line) || io_detail::trim(line) != "ply") fail(where, "not a PLY file (first line is not 'ply')");
  bool have_format = false, done = false;
  while (lines.next(line)) {
    const std::size_t ln = lines.lineNumber();
    io_detail::splitTokens(line, tok);
    if (tok.empty()) continue;
    const std::string_view key = tok[0];
    if (key == "comment" || key == "obj_info") {
      if (line.find(kHazmapMarker) != std::string_view::npos) h.hazmap_classes = true;
      continue;
    }
    if (key == "format") {
      if (tok.size() != 3) io_detail::failAtLine(path, ln, "format line needs a kind and a version");
      if (tok[1] == "ascii") h.format = PlyFormat::Ascii;
      else if (tok[1] == "binary_little_endian") h.format = PlyFormat::BinaryLittleEndian;
      else if (tok[1] == "binary_big_endian") h.format = PlyFormat::BinaryBigEndian;
      else
        io_detail::failAtLine(path, ln, "unknown format '" + std::string(tok[1].substr(0, 30)) +
                                            "' (expected ascii, binary_little_endian or binary_big_endian)");
      have_format = true;
    } else if (key == "element") {
      std::uint64_t count = 0;
      if (tok.size() != 3 || !io_detail::parseUint64(tok[2], count))
        io_detail::failAtLine(path, ln, "element line needs a name and a non-negative count");
      h.elements.push_back({std::string(tok[1]), count, {}, 0, true});
    } else if (key == "property") {
      if (h.elements.empty()) io_detail::failAtLine(path, ln, "property before any element");
      PlyElement& e = h.elements.back();
      PlyProperty p;
      if (tok.size() >= 2 && tok[1] == "list") {
        if (tok.size() != 5) io_detail::failAtLine(path, ln, "list property needs count type, item type and name");
        const auto ct = plyScalar(tok[2]);
        const auto it = plyScalar(tok[3]);
        if (!ct) io_detail::failAtLine(path, ln, "unknown type '" + std::string(tok[2].substr(0, 20)) + "'");
        if (!it) io_detail::failAtLine(path, ln, "unknown type '" + std::string(tok[3].substr(0, 20)) + "'");
        if (*ct == Scalar::F32 || *ct == Scalar::F64)
          io_detail::failAtLine(path, ln, "list count type must be an integer type");
        p = {std::string(tok[4]), *it, true, *ct};
        e.fixed = false;
        e.min_item_bytes += io_detail::scalarSize(*ct);
      } else {
        if (tok.size() != 3) io_detail::failAtLine(path, ln, "property line needs a type and a name");
        const auto t = plyScalar(tok[1]);
        if (!t) io_detail::failAtLine(path, ln, "unknown type '" + std::string(tok[1].substr(0, 20)) + "'");
        p = {std::string(tok[2]), *t, false, Scalar::U8};
        e.min_item_bytes += io_detail::scalarSize(*t);
      }
      for (const auto& q : e.props)
        if (q.name == p.name) io_detail::failAtLine(path, ln, "property '" + p.name + "' defined twice");
      e.props.push_back(p);
    } else if (key == "end_header") {
      h.data_offset = lines.offset();
      h.data_line = ln;
      done = true;
      break;
    } else {
      io_detail::failAtLine(path, ln, "unknown header line '" + std::string(key.substr(0, 30)) + "' (missing end_header?)");
    }
  }
  if (!done) fail(where, "header has no end_header line (truncated?)");
  if (!have_format) fail(where, "header has no format line");
  return h;
}

/// One item of an element: the values of its scalar properties and of its lists.
struct PlyItem {
  std::vector<double> scalars;             ///< one per property (lists: their length)
  std::vector<std::vector<double>> lists;  ///< one per property (empty for scalars)
};

/// Reads the body element after element. Items are decoded into a reused PlyItem, so reading
/// allocates nothing per item once list buffers reach their size.
class PlyBody {
 public:
  PlyBody(const PlyHeader& h, const io_detail::FileBytes& bytes, const std::filesystem::path& path)
      : h_(h), path_(path), text_(bytes.view()), pos_(h.data_offset),
        lines_(bytes.view().substr(h.data_offset), h.data_line + 1) {}

  /// Checks the element's item count against the bytes left (so absurd counts never allocate).
  void checkCount(const PlyElement& e) const {
    const std::size_t remaining = h_.format == PlyFormat::Ascii ? text_.size() - h_.data_offset - lines_.offset()
                                                                : text_.size() - pos_;
    const std::size_t per_item = h_.format == PlyFormat::Ascii ? 2 : std::max<std::size_t>(1, e.min_item_bytes);
    if (e.count > 0 && e.count - 1 > remaining / per_item)
      fail(path_.string(), "truncated: element '" + e.name + "' claims " + std::to_string(e.count) +
                               " items but only " + std::to_string(remaining) + " bytes of data follow");
  }

  template <typename Visit>
  void read(const PlyElement& e, Visit&& visit) {
    checkCount(e);
    PlyItem item;
    item.scalars.resize(e.props.size());
    item.lists.resize(e.props.size());
    for (std::uint64_t i = 0; i < e.count; ++i) {
      if (h_.format == PlyFormat::Ascii)
        readAscii(e, i, item);
      else
        readBinary(e, i, item);
      visit(static_cast<std::size_t>(i), item);
    }
  }

  void skip(const PlyElement& e) {
    checkCount(e);
    if (h_.format != PlyFormat::Ascii && e.fixed) {
      const std::size_t need = static_cast<std::size_t>(e.count) * e.min_item_bytes;
      if (need > text_.size() - pos_) truncated(e, 0);
      pos_ += need;
      return;
    }
    read(e, [](std::size_t, const PlyItem&) {});
  }

 private:
  [[noreturn]] void truncated(const PlyElement& e, std::uint64_t i) const {
    fail(path_.string(), "truncated: data ends inside element '" + e.name + "' (item " + std::to_string(i) +
                             " of " + std::to_string(e.count) + ")");
  }

  void readBinary(const PlyElement& e, std::uint64_t i, PlyItem& item) {
    const bool swap = h_.format == PlyFormat::BinaryBigEndian;
    const std::size_t end = text_.size();
    for (std::size_t k = 0; k < e.props.size(); ++k) {
      const PlyProperty& p = e.props[k];
      if (!p.is_list) {
        const std::size_t sz = io_detail::scalarSize(p.type);
        if (end - pos_ < sz) truncated(e, i);
        item.scalars[k] = io_detail::loadScalar(text_.data() + pos_, p.type, swap);
        pos_ += sz;
        continue;
      }
      const std::size_t csz = io_detail::scalarSize(p.count_type);
      if (end - pos_ < csz) truncated(e, i);
      const double c = io_detail::loadScalar(text_.data() + pos_, p.count_type, swap);
      pos_ += csz;
      if (c < 0) fail(path_.string(), "element '" + e.name + "' item " + std::to_string(i) + ": negative list length");
      const std::size_t sz = io_detail::scalarSize(p.type);
      if (c > double((end - pos_) / sz)) truncated(e, i);
      const auto count = static_cast<std::size_t>(c);
      item.scalars[k] = c;
      auto& list = item.lists[k];
      list.resize(count);
      for (std::size_t j = 0; j < count; ++j) list[j] = io_detail::loadScalar(text_.data() + pos_ + j * sz, p.type, swap);
      pos_ += count * sz;
    }
  }

  void readAscii(const PlyElement& e, std::uint64_t i, PlyItem& item) {
    std::string_view line;
    do {
      if (!lines_.next(line)) truncated(e, i);
      io_detail::splitTokens(line, tok_);
    } while (tok_.empty());
    const std::size_t ln = lines_.lineNumber();
    std::size_t t = 0;
    const auto next = [&]() -> double {
      if (t >= tok_.size())
        io_detail::failAtLine(path_, ln, "too few values for element '" + e.name + "'");
      return io_detail::numberAt(tok_[t++], path_, ln);
    };
    for (std::size_t k = 0; k < e.props.size(); ++k) {
      const PlyProperty& p = e.props[k];
      if (!p.is_list) {
        item.scalars[k] = next();
        continue;
      }
      const double c = next();
      if (!(c >= 0) || c != std::floor(c) || c > double(tok_.size()))
        io_detail::failAtLine(path_, ln, "bad list length " + std::to_string(c));
      const auto count = static_cast<std::size_t>(c);
      item.scalars[k] = c;
      auto& list = item.lists[k];
      list.resize(count);
      for (std::size_t j = 0; j < count; ++j) list[j] = next();
    }
    if (t != tok_.size())
      io_detail::failAtLine(path_, ln, "expected " + std::to_string(t) + " values for element '" + e.name +
                                           "', found " + std::to_string(tok_.size()));
  }

  const PlyHeader& h_;
  const std::filesystem::path& path_;
  std::string_view text_;
  std::size_t pos_;
  io_detail::LineReader lines_;
  std::vector<std::string_view> tok_;
};

/// A scalar (non-list) property index by any of `names`, or npos.
template <typename Names>
std::size_t scalarProp(const PlyElement& e, const Names& names) {
  for (const char* n : names) {
    const std::size_t k = e.index(n);
    if (k != PlyElement::npos && !e.props[k].is_list) return k;
  }
  return PlyElement::npos;
}

std::size_t requireXyz(const PlyElement& e, const char* axis, const std::filesystem::path& path) {
  const std::size_t k = e.index(axis);
  if (k == PlyElement::npos) fail(path.string(), std::string("missing vertex property '") + axis + "'");
  if (e.props[k].is_list) fail(path.string(), std::string("vertex property '") + axis + "' is a list");
  return k;
}

/// Serialises rows of typed values as PLY ascii or binary_little_endian.
class PlyWriter {
 public:
  explicit PlyWriter(bool binary) : binary_(binary) {}
  template <typename T>
  void put(T v) {
    if (binary_) {
      const std::size_t at = body_.size();
      body_.resize(at + sizeof(T));
      std::memcpy(body_.data() + at, &v, sizeof(T));
      return;
    }
    if (!row_start_) body_ += ' ';
    row_start_ = false;
    if constexpr (std::is_floating_point_v<T>)
      io_detail::appendNumber(body_, v);
    else
      io_detail::appendNumber(body_, static_cast<std::uint64_t>(v));
  }
  void endRow() {
    if (!binary_) body_ += '\n';
    row_start_ = true;
  }
  std::string& body() { return body_; }

 private:
  bool binary_;
  bool row_start_ = true;
  std::string body_;
};

}  // namespace

LabeledCloud readPly(const std::filesystem::path& path, const ClassTable& table, ReadStats* stats) {
  const std::string where = path.string();
  const io_detail::FileBytes bytes = io_detail::readFileBytes(path);
  const PlyHeader h = parseHeader(bytes.view(), path);
  PlyBody body(h, bytes, path);
  const PlyElement* vertex = nullptr;
  for (const auto& e : h.elements)
    if (e.name == "vertex") vertex = &e;
  if (!vertex) fail(where, "no 'vertex' element");
  const std::size_t kx = requireXyz(*vertex, "x", path), ky = requireXyz(*vertex, "y", path),
                    kz = requireXyz(*vertex, "z", path);
  const std::size_t ki = scalarProp(*vertex, io_fields::kIntensityNames);
  const std::size_t kl = scalarProp(*vertex, io_fields::kLabelNames);
  const std::size_t kt = scalarProp(*vertex, io_fields::kTimeNames);
  const std::size_t kp = scalarProp(*vertex, io_fields::kPropertyNames);
  const auto npos = PlyElement::npos;
  const PlyProperty* marker = &vertex->props[kx];  // any non-null pointer marks "present"
  io_fields::ChannelSink sink(where, table, h.hazmap_classes, ki != npos ? marker : nullptr,
                              kl != npos ? marker : nullptr, kt != npos ? marker : nullptr,
                              kp != npos ? marker : nullptr);
  for (const auto& e : h.elements) {
    if (&e != vertex) {
      body.skip(e);
      continue;
    }
    body.checkCount(e);
    sink.reserve(e.count);
    body.read(e, [&](std::size_t i, const PlyItem& it) {
      const auto v = [&](std::size_t k) { return k == npos ? 0.0 : it.scalars[k]; };
      sink.add(v(kx), v(ky), v(kz), v(ki), v(kl), v(kt), v(kp), i);
    });
    break;  // later elements (faces) are not needed for a cloud
  }
  if (stats) {
    stats->format = h.format == PlyFormat::Ascii                ? "ply ascii"
                    : h.format == PlyFormat::BinaryLittleEndian ? "ply binary_little_endian"
                                                                : "ply binary_big_endian";
    stats->fields.clear();
    for (const auto& p : vertex->props) stats->fields.push_back(p.name);
  }
  return sink.finish(vertex->count, stats);
}

void writePly(const std::filesystem::path& path, const LabeledCloud& cloud, const PlyWriteOptions& options) {
  cloud.checkConsistent(path.string());
  const std::size_t n = cloud.size();
  if (!options.colors.empty() && options.colors.size() != n)
    fail(path.string(), "colour count " + std::to_string(options.colors.size()) + " differs from point count " +
                            std::to_string(n));
  const bool hi = !cloud.intensity.empty(), ht = !cloud.timestamps.empty(), hp = !cloud.property.empty();
  const bool hc = !options.colors.empty();
  std::string head = "ply\nformat ";
  head += options.binary ? "binary_little_endian 1.0\n" : "ascii 1.0\n";
  head += std::string("comment ") + kHazmapMarker + "\n";
  head += "element vertex " + std::to_string(n) + "\n";
  head += "property float x\nproperty float y\nproperty float z\n";
  if (hi) head += "property float intensity\n";
  head += "property ushort label\n";
  if (ht) head += "property double timestamp\n";
  if (hp) head += "property float property\n";
  if (hc) head += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  for (const auto& [name, values] : options.fields) {
    if (values.size() != n || name.empty() || name.find_first_of(" \t\n") != std::string::npos)
      fail(path.string(), "field '" + name + "' needs a name without spaces and one value per point");
    head += "property float " + name + "\n";
  }
  head += "end_header\n";
  PlyWriter w(options.binary);
  w.body() = std::move(head);
  w.body().reserve(w.body().size() + n * (options.binary ? 32 : 64));
  for (std::size_t i = 0; i < n; ++i) {
    const auto& p = cloud.points[i];
    w.put(p.x());
    w.put(p.y());
    w.put(p.z());
    if (hi) w.put(cloud.intensity[i]);
    w.put(static_cast<std::uint16_t>(cloud.classes[i]));
    if (ht) w.put(cloud.timestamps[i]);
    if (hp) w.put(cloud.property[i]);
    if (hc)
      for (int c = 0; c < 3; ++c) w.put(options.colors[i][c]);
    for (const auto& field : options.fields) w.put(field.second[i]);
    w.endRow();
  }
  writeTextAtomically(path, w.body());
}

TriangleMesh readPlyMesh(const std::filesystem::path& path) {
  const std::string where = path.string();
  const io_detail::FileBytes bytes = io_detail::readFileBytes(path);
  const PlyHeader h = parseHeader(bytes.view(), path);
  PlyBody body(h, bytes, path);
  TriangleMesh mesh;
  bool have_vertex = false, have_face = false;
  const auto npos = PlyElement::npos;
  for (const auto& e : h.elements) {
    if (e.name == "vertex" && !have_vertex) {
      have_vertex = true;
      const std::size_t kx = requireXyz(e, "x", path), ky = requireXyz(e, "y", path), kz = requireXyz(e, "z", path);
      std::size_t kr = scalarProp(e, std::array{"red", "diffuse_red"});
      std::size_t kg = scalarProp(e, std::array{"green", "diffuse_green"});
      std::size_t kb = scalarProp(e, std::array{"blue", "diffuse_blue"});
      const bool colors = kr != npos && kg != npos && kb != npos;
      body.checkCount(e);
      mesh.vertices.reserve(e.count);
      if (colors) mesh.vertex_colors.reserve(e.count);
      body.read(e, [&](std::size_t i, const PlyItem& it) {
        const Eigen::Vector3f p(float(it.scalars[kx]), float(it.scalars[ky]), float(it.scalars[kz]));
        if (!p.allFinite()) fail(where, "vertex " + std::to_string(i) + " has a non-finite coordinate");
        mesh.vertices.push_back(p);
        if (colors) {
          Rgb c;
          const std::size_t ks[3] = {kr, kg, kb};
          for (int j = 0; j < 3; ++j) {
            double v = it.scalars[ks[j]];
            if (e.props[ks[j]].type == Scalar::F32 || e.props[ks[j]].type == Scalar::F64) v *= 255.0;
            c[j] = static_cast<std::uint8_t>(std::clamp(std::isfinite(v) ? v : 0.0, 0.0, 255.0));
          }
          mesh.vertex_colors.push_back(c);
        }
      });
    } else if (e.name == "face" && !have_face) {
      have_face = true;
      std::size_t kv = e.index("vertex_indices");
      if (kv == npos) kv = e.index("vertex_index");
      if (kv == npos || !e.props[kv].is_list) fail(where, "face element has no 'vertex_indices' list");
      const std::size_t kl = scalarProp(e, io_fields::kLabelNames);
      body.checkCount(e);
      mesh.triangles.reserve(e.count);
      if (kl != npos) mesh.triangle_classes.reserve(e.count);
      body.read(e, [&](std::size_t i, const PlyItem& it) {
        const auto& idx = it.lists[kv];
        if (idx.size() < 3)
          fail(where, "face " + std::to_string(i) + " has " + std::to_string(idx.size()) + " vertices (need >= 3)");
        ClassId c = 0;
        if (kl != npos) {
          const double l = it.scalars[kl];
          if (!(l >= 0 && l <= 65535) || l != std::floor(l))
            fail(where, "face " + std::to_string(i) + ": label " + std::to_string(l) + " is not a class id (0..65535)");
          c = static_cast<ClassId>(l);
        }
        for (double v : idx)
          if (!(v >= 0 && v <= double(std::numeric_limits<int>::max())) || v != std::floor(v))
            fail(where, "face " + std::to_string(i) + ": vertex index " + std::to_string(v) + " is invalid");
        // Polygons are split into a triangle fan.
        for (std::size_t j = 1; j + 1 < idx.size(); ++j) {
          mesh.triangles.emplace_back(int(idx[0]), int(idx[j]), int(idx[j + 1]));
          if (kl != npos) mesh.triangle_classes.push_back(c);
        }
      });
    } else {
      body.skip(e);
    }
  }
  if (!have_vertex) fail(where, "no 'vertex' element");
  const auto nv = static_cast<int>(mesh.vertices.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int j = 0; j < 3; ++j)
      if (mesh.triangles[t][j] < 0 || mesh.triangles[t][j] >= nv)
        fail(where, "triangle " + std::to_string(t) + " refers to vertex " + std::to_string(mesh.triangles[t][j]) +
                        " but there are " + std::to_string(nv) + " vertices");
  return mesh;
}

void writePlyMesh(const std::filesystem::path& path, const TriangleMesh& mesh, bool binary) {
  const std::string where = path.string();
  if (!mesh.vertex_colors.empty() && mesh.vertex_colors.size() != mesh.vertices.size())
    fail(where, "vertex colour count differs from vertex count");
  if (!mesh.triangle_classes.empty() && mesh.triangle_classes.size() != mesh.triangles.size())
    fail(where, "triangle class count differs from triangle count");
  const auto nv = static_cast<long long>(mesh.vertices.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int j = 0; j < 3; ++j)
      if (mesh.triangles[t][j] < 0 || mesh.triangles[t][j] >= nv)
        fail(where, "triangle " + std::to_string(t) + " refers to missing vertex " +
                        std::to_string(mesh.triangles[t][j]));
  const bool hc = !mesh.vertex_colors.empty(), hl = !mesh.triangle_classes.empty();
  std::string head = "ply\nformat ";
  head += binary ? "binary_little_endian 1.0\n" : "ascii 1.0\n";
  head += std::string("comment ") + kHazmapMarker + "\n";
  head += "element vertex " + std::to_string(mesh.vertices.size()) + "\n";
  head += "property float x\nproperty float y\nproperty float z\n";
  if (hc) head += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  head += "element face " + std::to_string(mesh.triangles.size()) + "\n";
  head += "property list uchar int vertex_indices\n";
  if (hl) head += "property ushort label\n";
  head += "end_header\n";
  PlyWriter w(binary);
  w.body() = std::move(head);
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    for (int k = 0; k < 3; ++k) w.put(mesh.vertices[i][k]);
    if (hc)
      for (int c = 0; c < 3; ++c) w.put(mesh.vertex_colors[i][c]);
    w.endRow();
  }
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    w.put(std::uint8_t{3});
    for (int k = 0; k < 3; ++k) w.put(static_cast<std::int32_t>(mesh.triangles[t][k]));
    if (hl) w.put(static_cast<std::uint16_t>(mesh.triangle_classes[t]));
    w.endRow();
  }
  writeTextAtomically(path, w.body());
}

}  // namespace hazmap
