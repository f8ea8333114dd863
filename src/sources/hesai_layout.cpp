// The Hesai models' packet layouts and firing times (the manuals' "Data Packet Format" and
// "Laser Firing Time" sections; nebula's sensor definitions agree).
#include "sources/hesai_layout.hpp"

#include <algorithm>
#include <array>
#include <cctype>

namespace hazmap {
namespace hesai_detail {

namespace {

constexpr std::size_t blockBytes(int channels, int unit, int azimuth_at) {
  return static_cast<std::size_t>(azimuth_at + 2 + channels * unit);
}

// Tails: 40P/64 = reserved 5, high-temperature flag, reserved 2, motor speed u16, timestamp u32,
// return mode, factory byte, date (6); XT = reserved 10, return mode, motor speed, date,
// timestamp, factory byte; QT64 = reserved 10, motor speed, timestamp, return mode, factory,
// date; QT128 = reserved 5, mode flag, reserved 6, return mode, motor speed, date, timestamp,
// factory byte, UDP sequence, tail CRC.
const std::array<HesaiLayout, 7> kLayouts = {{
    {HesaiModel::Pandar40P, 1240 + 22, 0, 10, 40, 3, 2, blockBytes(40, 3, 2), 1240 + 14, -1, 0.3f, 200.f},
    {HesaiModel::Pandar64, 8 + 1164 + 22, 8, 6, 64, 3, 0, blockBytes(64, 3, 0), 8 + 1164 + 14, 5, 0.3f, 200.f},
    {HesaiModel::PandarQT64, 12 + 1032 + 24, 12, 4, 64, 4, 0, blockBytes(64, 4, 0), 12 + 1032 + 16, 9, 0.1f, 60.f},
    {HesaiModel::PandarQT128, 12 + 1032 + 17 + 34, 12, 2, 128, 4, 0, blockBytes(128, 4, 0), 12 + 1032 + 17 + 12, 9,
     0.05f, 50.f},
    {HesaiModel::PandarXT16, 12 + 528 + 24, 12, 8, 16, 4, 0, blockBytes(16, 4, 0), 12 + 528 + 10, 9, 0.05f, 120.f},
    {HesaiModel::PandarXT32, 12 + 1040 + 24, 12, 8, 32, 4, 0, blockBytes(32, 4, 0), 12 + 1040 + 10, 9, 0.05f, 120.f},
    {HesaiModel::PandarXT32M, 12 + 780 + 24, 12, 6, 32, 4, 0, blockBytes(32, 4, 0), 12 + 780 + 10, 9, 0.5f, 300.f},
}};

}  // namespace

const HesaiLayout& hesaiLayout(HesaiModel model) { return kLayouts[static_cast<std::size_t>(model)]; }

int returnsOfMode(std::uint8_t mode) {
  if (mode >= 0x33 && mode <= 0x38) return 1;
  if ((mode >= 0x39 && mode <= 0x3c) || mode == 0x3e) return 2;
  if (mode == 0x3d) return 3;
  return 0;
}

/// Firings are 55.56 µs apart on the 40P and 64 (the timestamp after the last), 50 µs on the XT
/// (the timestamp 5.632 µs after the last), 166.67 µs on the QT64 and 111.11 µs on the QT128
/// (the timestamp before the first).
double HesaiLayout::blockOffsetNs(int b, int n) const {
  const int firing = b / n, firings = blocks / n;
  switch (model) {
    case HesaiModel::Pandar40P: return -28580.0 - 55560.0 * (firings - 1 - firing);
    case HesaiModel::Pandar64: return -42580.0 - 55560.0 * (firings - 1 - firing);
    case HesaiModel::PandarQT64: return 25710.0 + 500000.0 / 3.0 * firing;
    case HesaiModel::PandarQT128: return 9000.0 + 111110.0 * firing;
    case HesaiModel::PandarXT16:
    case HesaiModel::PandarXT32:
    case HesaiModel::PandarXT32M: return 5632.0 - 50000.0 * (firings - 1 - firing);
  }
  return 0.0;
}

/// The XT models fire their channels one after another (1.512 µs apart on the XT32, 3.024 µs on
/// the XT16, two banks of 16 2.888 µs apart on the XT32M); the 40P, 64 and QT fire in an
/// interleaved order within at most 60 µs (≈ 0.02° at 10 Hz), not modelled.
double HesaiLayout::channelOffsetNs(int c) const {
  switch (model) {
    case HesaiModel::PandarXT16: return 368.0 + 3024.0 * c;
    case HesaiModel::PandarXT32: return 368.0 + 1512.0 * c;
    case HesaiModel::PandarXT32M: return 368.0 + 2888.0 * (c % 16);
    default: return 0.0;
  }
}

}  // namespace hesai_detail

using hesai_detail::kLayouts;

const char* hesaiModelName(HesaiModel model) {
  static const char* const names[] = {"Pandar40P", "Pandar64", "PandarQT64", "PandarQT128",
                                      "PandarXT16", "PandarXT32", "PandarXT32M"};
  return names[static_cast<int>(model)];
}

std::optional<HesaiModel> hesaiModelFromName(const std::string& name) {
  std::string n;
  for (char c : name) n += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (n.rfind("pandar", 0) == 0) n = n.substr(6);
  for (const auto& l : kLayouts) {
    std::string m;
    for (const char* p = hesaiModelName(l.model) + 6; *p; ++p)
      m += static_cast<char>(std::tolower(static_cast<unsigned char>(*p)));
    if (m == n) return l.model;
  }
  return std::nullopt;
}

int hesaiChannelCount(HesaiModel model) { return hesai_detail::hesaiLayout(model).channels; }

std::optional<HesaiModel> hesaiModelOfPacket(std::span<const std::uint8_t> p) {
  if (p.size() < 12) return std::nullopt;
  std::optional<HesaiModel> model;
  if (p[0] == 0xff && p[1] == 0xee) model = HesaiModel::Pandar40P;
  else if (p[0] != 0xee || p[1] != 0xff) return std::nullopt;
  else if (p[2] == 64 && p[3] == 6) model = HesaiModel::Pandar64;  // the 8-byte header
  else
    for (const auto& l : kLayouts)
      if (l.header == 12 && p[6] == l.channels && p[7] == l.blocks) model = l.model;
  // Optional trailers (UDP sequence, cyber-security signature) follow the tail.
  if (model && p.size() >= hesai_detail::hesaiLayout(*model).size && p.size() <= hesai_detail::hesaiLayout(*model).size + 64)
    return model;
  return std::nullopt;
}

}  // namespace hazmap
