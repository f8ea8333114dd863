#include "sources/packet_decoders.hpp"

#include "hazmap/core/error.hpp"
#include "hazmap/sources/ouster.hpp"
#include "hazmap/sources/velodyne.hpp"

namespace hazmap::sources {

std::unique_ptr<PacketDecoder> makeVelodyneDecoderFor(const ScanSourceOptions& options) {
  VelodyneOptions velodyne;
  velodyne.calibration_file = options.velodyne_calibration;
  return makeVelodyneDecoder(velodyne);
}

std::unique_ptr<PacketDecoder> makeOusterDecoderFor(const std::string& metadata_json, const std::string& where) {
  return makeOusterDecoder(parseOusterMetadata(metadata_json, where));
}

}  // namespace hazmap::sources
