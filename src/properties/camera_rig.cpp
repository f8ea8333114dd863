#include "hazmap/properties/camera_rig.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"

namespace hazmap {

namespace fs = std::filesystem;

namespace {

YAML::Node load(const std::string& yaml, const std::string& where) {
  try {
    return YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    fail(where, std::string("not valid YAML: ") + e.what());
  }
}

}  // namespace

bool isCameraRig(const fs::path& path) {
  if (!fs::is_regular_file(path)) return false;  // readCameraYaml names the missing file
  try {
    const YAML::Node root = YAML::Load(readTextFile(path));
    return root.IsMap() && root["cameras"];
  } catch (const YAML::Exception&) {
    return false;  // not YAML at all: the camera reader says so
  }
}

std::vector<fs::path> parseCameraRig(const std::string& yaml, const std::string& where, const fs::path& base_dir) {
  const YAML::Node root = load(yaml, where);
  if (!root.IsMap()) fail(where, "a camera rig must be a YAML mapping with 'cameras:'");
  for (const auto& kv : root)
    if (!kv.first.IsScalar() || kv.first.Scalar() != "cameras")
      fail(where, "unknown key '" + (kv.first.IsScalar() ? kv.first.Scalar() : std::string("?")) + "' in a camera rig");
  const YAML::Node list = root["cameras"];
  if (!list || !list.IsSequence() || list.size() == 0) fail(where, "'cameras' must be a non-empty list of camera files");
  std::vector<fs::path> out;
  for (std::size_t k = 0; k < list.size(); ++k) {
    if (!list[k].IsScalar() || list[k].Scalar().empty())
      fail(where, "cameras[" + std::to_string(k) + "] must be a camera.yaml file name");
    const fs::path p = list[k].Scalar();
    out.push_back(p.is_absolute() || base_dir.empty() ? p : (base_dir / p).lexically_normal());
  }
  return out;
}

std::vector<fs::path> expandCameraFiles(const std::vector<fs::path>& files) {
  std::vector<fs::path> out;
  for (const fs::path& f : files) {
    if (!isCameraRig(f)) {
      out.push_back(f);
      continue;
    }
    const auto listed = parseCameraRig(readTextFile(f), f.string(), fs::absolute(f).parent_path());
    for (const fs::path& c : listed)
      if (isCameraRig(c)) fail(f.string(), "lists another rig (" + c.string() + "); list camera files");
    out.insert(out.end(), listed.begin(), listed.end());
  }
  for (std::size_t i = 0; i < out.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (fs::absolute(out[i]).lexically_normal() == fs::absolute(out[j]).lexically_normal())
        fail(out[i].string(), "camera given twice");
  return out;
}

}  // namespace hazmap
