#pragma once
// A camera rig file: several calibrated cameras given as one --camera argument.
//
//   # rig.yaml
//   cameras:
//     - thermal_front/camera.yaml   # paths relative to this file
//     - thermal_left/camera.yaml
//
// Each listed camera keeps its own calibration, clock, channel and images (or topic). A point
// seen by several cameras of one channel takes the view with the smallest calibration footprint
// (view_fusion.hpp; docs/properties.md "Camera rigs").
#include <filesystem>
#include <string>
#include <vector>

namespace hazmap {

/// True when the YAML file is a rig (a mapping with `cameras:`), not a camera calibration.
bool isCameraRig(const std::filesystem::path& path);
/// The camera files a rig lists, resolved against `base_dir`. Throws hazmap::Error naming
/// `where` for anything but a mapping with a non-empty `cameras:` list of file names.
std::vector<std::filesystem::path> parseCameraRig(const std::string& yaml, const std::string& where,
                                                  const std::filesystem::path& base_dir);
/// The --camera arguments with every rig file replaced by the cameras it lists (in order);
/// a camera given twice is an error naming it.
std::vector<std::filesystem::path> expandCameraFiles(const std::vector<std::filesystem::path>& files);

}  // namespace hazmap
