#pragma once
// The packet decoders a scan stream needs, made from the user's options: Velodyne (model from the
// packets, factory or YAML calibration), Hesai (model from the packets, built-in or CSV angle
// corrections) and Ouster (from the sensor's metadata JSON).
#include <memory>
#include <string>

#include "hazmap/sources/packet_decoder.hpp"
#include "hazmap/sources/scan_source.hpp"

namespace hazmap::sources {

std::unique_ptr<PacketDecoder> makeVelodyneDecoderFor(const ScanSourceOptions& options);
/// Hesai (model from the packets or options.sensor, built-in or CSV angle corrections).
std::unique_ptr<PacketDecoder> makeHesaiDecoderFor(const ScanSourceOptions& options);
/// Whether options.sensor names a Hesai model (a capture is then read as Hesai).
bool sensorIsHesai(const ScanSourceOptions& options);
/// `metadata_json`: the sensor's metadata (text); `where` names where it came from.
std::unique_ptr<PacketDecoder> makeOusterDecoderFor(const std::string& metadata_json, const std::string& where);

}  // namespace hazmap::sources
