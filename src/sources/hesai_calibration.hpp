#pragma once
// Built-in Hesai angle corrections (hesai_default_angles.cpp); internal to the Hesai decoder.
#include <span>

#include "hazmap/sources/hesai.hpp"

namespace hazmap::hesai_detail {

struct ChannelAngles {
  double elevation_deg, azimuth_deg;
};

/// The model's default angle-correction table (empty for the PandarXT16, whose nominal angles
/// hesaiDefaultCalibration computes).
std::span<const ChannelAngles> defaultAngles(HesaiModel model);

}  // namespace hazmap::hesai_detail
