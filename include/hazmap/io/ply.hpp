#pragma once
// PLY (ascii and binary_little_endian): point clouds (vertex x y z + optional intensity, label,
// red green blue, property) and triangle meshes (faces with an optional per-face label), the
// latter for simulator scenes.
#include <Eigen/Core>
#include <filesystem>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/io/read_stats.hpp"

namespace hazmap {

struct PlyWriteOptions {
  bool binary = true;
  /// Per-point colours (size() entries) written as red/green/blue; empty = no colour.
  std::vector<Rgb> colors;
  /// Further per-point float properties (name, size() values), written after the colours:
  /// e.g. a map's value of each camera channel (temperature, nir_reflectance; NaN = none).
  std::vector<std::pair<std::string, std::vector<float>>> fields;
};

LabeledCloud readPly(const std::filesystem::path& path, const ClassTable& table = ClassTable::defaults(),
                     ReadStats* stats = nullptr);
void writePly(const std::filesystem::path& path, const LabeledCloud& cloud,
              const PlyWriteOptions& options = {});

struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3i> triangles;
  std::vector<ClassId> triangle_classes;  ///< empty or one per triangle
  std::vector<Rgb> vertex_colors;         ///< empty or one per vertex
};

TriangleMesh readPlyMesh(const std::filesystem::path& path);
void writePlyMesh(const std::filesystem::path& path, const TriangleMesh& mesh, bool binary = true);

}  // namespace hazmap
