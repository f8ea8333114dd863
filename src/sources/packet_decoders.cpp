#include "sources/packet_decoders.hpp"

#include "hazmap/core/error.hpp"
#include "hazmap/sources/hesai.hpp"
#include "hazmap/sources/ouster.hpp"
#include "hazmap/sources/velodyne.hpp"

namespace hazmap::sources {

namespace {

std::optional<VelodyneModel> velodyneModelNamed(const std::string& name) {
  for (VelodyneModel m : {VelodyneModel::VLP16, VelodyneModel::VLP32C, VelodyneModel::HDL32E, VelodyneModel::VLS128})
    if (name == velodyneModelName(m)) return m;
  return std::nullopt;
}

/// options.sensor must name a model of the kind the recording holds.
void checkSensorName(const ScanSourceOptions& options, bool hesai) {
  if (options.sensor.empty() || (hesai ? hesaiModelFromName(options.sensor).has_value()
                                       : velodyneModelNamed(options.sensor).has_value()))
    return;
  fail("--sensor", "'" + options.sensor + "' is no " + (hesai ? "Hesai" : "Velodyne") +
                       " model; Hesai: Pandar40P, Pandar64, PandarQT64, PandarQT128, PandarXT16, PandarXT32, "
                       "PandarXT32M; Velodyne: VLP-16, VLP-32C, HDL-32E, VLS-128");
}

}  // namespace

std::unique_ptr<PacketDecoder> makeVelodyneDecoderFor(const ScanSourceOptions& options) {
  checkSensorName(options, false);
  VelodyneOptions velodyne;
  velodyne.calibration_file = options.velodyne_calibration;
  velodyne.model = velodyneModelNamed(options.sensor);
  return makeVelodyneDecoder(velodyne);
}

std::unique_ptr<PacketDecoder> makeHesaiDecoderFor(const ScanSourceOptions& options) {
  checkSensorName(options, true);
  HesaiOptions hesai;
  hesai.calibration_file = options.hesai_calibration;
  hesai.model = hesaiModelFromName(options.sensor);
  return makeHesaiDecoder(hesai);
}

bool sensorIsHesai(const ScanSourceOptions& options) {
  return !options.sensor.empty() && hesaiModelFromName(options.sensor).has_value();
}

std::unique_ptr<PacketDecoder> makeOusterDecoderFor(const std::string& metadata_json, const std::string& where) {
  return makeOusterDecoder(parseOusterMetadata(metadata_json, where));
}

}  // namespace hazmap::sources
