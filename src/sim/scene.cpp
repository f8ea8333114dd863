#include "hazmap/sim/scene.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <set>
#include <sstream>

#include "hazmap/core/error.hpp"

namespace hazmap::sim {

PropertyRegion PropertyRegion::box(std::string name, ClassId id, const Eigen::Vector3d& min,
                                   const Eigen::Vector3d& max) {
  PropertyRegion r;
  r.name = std::move(name);
  r.class_id = id;
  r.shape = Shape::Box;
  r.box_min = min;
  r.box_max = max;
  return r;
}

PropertyRegion PropertyRegion::prism(std::string name, ClassId id,
                                     std::vector<Eigen::Vector2d> polygon, double z_min,
                                     double z_max) {
  PropertyRegion r;
  r.name = std::move(name);
  r.class_id = id;
  r.shape = Shape::Polygon;
  r.polygon = std::move(polygon);
  r.z_min = z_min;
  r.z_max = z_max;
  return r;
}

bool PropertyRegion::contains(const Eigen::Vector3d& p) const {
  if (shape == Shape::Box)
    return (p.array() >= box_min.array()).all() && (p.array() <= box_max.array()).all();
  if (p.z() < z_min || p.z() > z_max) return false;
  // Even-odd rule: count polygon edges crossed by a ray from p towards +x.
  bool inside = false;
  const std::size_t n = polygon.size();
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const Eigen::Vector2d& a = polygon[i];
    const Eigen::Vector2d& b = polygon[j];
    if ((a.y() > p.y()) != (b.y() > p.y())) {
      const double x_cross = a.x() + (p.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
      if (p.x() < x_cross) inside = !inside;
    }
  }
  return inside;
}

Eigen::Vector3d PropertyRegion::boundsMin() const {
  if (shape == Shape::Box) return box_min;
  Eigen::Vector3d m(INFINITY, INFINITY, z_min);
  for (const auto& p : polygon) m.head<2>() = m.head<2>().cwiseMin(p);
  return m;
}

Eigen::Vector3d PropertyRegion::boundsMax() const {
  if (shape == Shape::Box) return box_max;
  Eigen::Vector3d m(-INFINITY, -INFINITY, z_max);
  for (const auto& p : polygon) m.head<2>() = m.head<2>().cwiseMax(p);
  return m;
}

double Route::polylineLength() const {
  double length = 0.0;
  for (std::size_t i = 1; i < waypoints.size(); ++i) length += (waypoints[i] - waypoints[i - 1]).norm();
  return length;
}

ClassId Scene::classAt(const Eigen::Vector3d& p) const {
  const PropertyRegion* r = regionAt(p);
  return r ? r->class_id : 0;
}

const PropertyRegion* Scene::regionAt(const Eigen::Vector3d& p) const {
  for (const auto& r : regions)
    if (r.contains(p)) return &r;
  return nullptr;
}

void Scene::labelTriangles() {
  mesh.triangle_classes.assign(mesh.triangles.size(), 0);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const Eigen::Vector3d c = (mesh.vertices[tri[0]] + mesh.vertices[tri[1]] + mesh.vertices[tri[2]])
                                  .cast<double>() / 3.0;
    mesh.triangle_classes[t] = classAt(c);
  }
}

std::vector<ClassId> Scene::regionClasses() const {
  std::set<ClassId> ids;
  for (const auto& r : regions) ids.insert(r.class_id);
  return {ids.begin(), ids.end()};
}

void Scene::validate(const ClassTable& table, const std::string& where) const {
  if (mesh.triangles.empty() || mesh.vertices.empty()) fail(where, "scene mesh is empty (no triangles)");
  for (const auto& v : mesh.vertices)
    if (!v.allFinite()) fail(where, "scene mesh has a non-finite vertex");
  const int nv = static_cast<int>(mesh.vertices.size());
  for (const auto& t : mesh.triangles)
    if (t.minCoeff() < 0 || t.maxCoeff() >= nv)
      fail(where, "scene mesh has a triangle with a vertex index out of range");
  for (const auto& r : regions) {
    if (!table.contains(r.class_id))
      fail(where, "region '" + r.name + "' has unknown class " + std::to_string(r.class_id));
    if (r.shape == PropertyRegion::Shape::Polygon && r.polygon.size() < 3)
      fail(where, "region '" + r.name + "' polygon needs at least 3 points");
    if ((r.boundsMin().array() > r.boundsMax().array()).any())
      fail(where, "region '" + r.name + "' has min > max");
  }
  if (route.waypoints.size() < 2) fail(where, "route needs at least 2 waypoints");
  for (std::size_t i = 1; i < route.waypoints.size(); ++i)
    if ((route.waypoints[i] - route.waypoints[i - 1]).norm() < 1e-6)
      fail(where, "route waypoints " + std::to_string(i - 1) + " and " + std::to_string(i) +
                      " coincide");
  if (!(route.corner_radius >= 0.0)) fail(where, "route corner_radius must be >= 0");
}

// ---- YAML regions -------------------------------------------------------------------------

namespace {

double toDouble(const YAML::Node& n, const std::string& where, const std::string& what) {
  try {
    const double v = n.as<double>();
    if (!std::isfinite(v)) fail(where, what + " must be a finite number");
    return v;
  } catch (const YAML::Exception&) {
    fail(where, what + " must be a number");
  }
}

Eigen::Vector3d toVec3(const YAML::Node& n, const std::string& where, const std::string& what) {
  if (!n || !n.IsSequence() || n.size() != 3) fail(where, what + " must be [x, y, z]");
  return {toDouble(n[0], where, what), toDouble(n[1], where, what), toDouble(n[2], where, what)};
}

Eigen::Vector2d toVec2(const YAML::Node& n, const std::string& where, const std::string& what) {
  if (!n || !n.IsSequence() || n.size() != 2) fail(where, what + " must be [x, y]");
  return {toDouble(n[0], where, what), toDouble(n[1], where, what)};
}

ClassId classFromNode(const YAML::Node& n, const ClassTable& table, const std::string& where,
                      const std::string& region) {
  const std::string text = n.as<std::string>("");
  for (ClassId id : table.ids())
    if (table.at(id).name == text) return id;
  char* end = nullptr;
  const long id = std::strtol(text.c_str(), &end, 10);
  if (!text.empty() && end && *end == '\0' && id >= 0 && id <= 65535 &&
      table.contains(static_cast<ClassId>(id)))
    return static_cast<ClassId>(id);
  fail(where, "region '" + region + "' has unknown class '" + text + "'");
}

void checkKeys(const YAML::Node& map, std::initializer_list<const char*> known,
               const std::string& where, const std::string& what) {
  for (const auto& kv : map) {
    const std::string key = kv.first.as<std::string>("");
    bool ok = false;
    for (const char* k : known) ok = ok || key == k;
    if (!ok) fail(where, what + ": unknown key '" + key + "'");
  }
}

}  // namespace

void parseRegionsYaml(const std::string& yaml, const std::string& where, const ClassTable& table,
                      Scene& scene) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    fail(where, std::string("invalid YAML: ") + e.msg + " at line " + std::to_string(e.mark.line + 1));
  }
  if (!root.IsMap()) fail(where, "expected a mapping with 'regions' and 'route'");
  checkKeys(root, {"regions", "route"}, where, "top level");
  if (const YAML::Node regions = root["regions"]) {
    if (!regions.IsSequence()) fail(where, "'regions' must be a list");
    std::size_t index = 0;
    for (const auto& r : regions) {
      const std::string label = "regions[" + std::to_string(index++) + "]";
      if (!r.IsMap()) fail(where, label + " must be a mapping");
      checkKeys(r, {"name", "class", "box", "polygon", "z"}, where, label);
      const std::string name = r["name"] ? r["name"].as<std::string>("") : label;
      if (!r["class"]) fail(where, "region '" + name + "' has no 'class'");
      const ClassId id = classFromNode(r["class"], table, where, name);
      if (r["box"] && r["polygon"]) fail(where, "region '" + name + "' has both 'box' and 'polygon'");
      if (const YAML::Node box = r["box"]) {
        if (!box.IsMap()) fail(where, "region '" + name + "': box must be {min: [..], max: [..]}");
        const Eigen::Vector3d lo = toVec3(box["min"], where, "region '" + name + "' box min");
        const Eigen::Vector3d hi = toVec3(box["max"], where, "region '" + name + "' box max");
        if ((lo.array() > hi.array()).any()) fail(where, "region '" + name + "' box has min > max");
        scene.regions.push_back(PropertyRegion::box(name, id, lo, hi));
      } else if (const YAML::Node poly = r["polygon"]) {
        if (!poly.IsSequence() || poly.size() < 3)
          fail(where, "region '" + name + "': polygon needs at least 3 [x, y] points");
        std::vector<Eigen::Vector2d> pts;
        for (const auto& p : poly) pts.push_back(toVec2(p, where, "region '" + name + "' polygon point"));
        const Eigen::Vector2d z = toVec2(r["z"], where, "region '" + name + "' z ([z_min, z_max])");
        if (z.x() > z.y()) fail(where, "region '" + name + "': z_min > z_max");
        scene.regions.push_back(PropertyRegion::prism(name, id, std::move(pts), z.x(), z.y()));
      } else {
        fail(where, "region '" + name + "' needs a 'box' or a 'polygon'");
      }
    }
  }
  if (const YAML::Node route = root["route"]) {
    if (!route.IsMap()) fail(where, "'route' must be a mapping with 'waypoints'");
    checkKeys(route, {"waypoints", "corner_radius", "floor_z", "loop_waypoints"}, where, "route");
    const YAML::Node wps = route["waypoints"];
    if (!wps || !wps.IsSequence() || wps.size() < 2)
      fail(where, "route needs a 'waypoints' list of at least 2 [x, y] points");
    scene.route = Route{};
    for (const auto& w : wps) scene.route.waypoints.push_back(toVec2(w, where, "route waypoint"));
    if (route["corner_radius"]) {
      scene.route.corner_radius = toDouble(route["corner_radius"], where, "route corner_radius");
      if (scene.route.corner_radius < 0.0) fail(where, "route corner_radius must be >= 0");
    }
    if (route["floor_z"]) scene.route.floor_z = toDouble(route["floor_z"], where, "route floor_z");
    if (route["loop_waypoints"]) {
      const double n = toDouble(route["loop_waypoints"], where, "route loop_waypoints");
      if (n < 0 || n > static_cast<double>(scene.route.waypoints.size()) || n != std::floor(n))
        fail(where, "route loop_waypoints must be an integer in [0, number of waypoints]");
      scene.route.loop_waypoints = static_cast<std::size_t>(n);
    }
  }
}

namespace {

/// Shortest text that reads back as exactly `v`.
std::string num(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string point(const Eigen::Vector2d& p) { return "[" + num(p.x()) + ", " + num(p.y()) + "]"; }
std::string point(const Eigen::Vector3d& p) {
  return "[" + num(p.x()) + ", " + num(p.y()) + ", " + num(p.z()) + "]";
}

}  // namespace

std::string regionsToYaml(const Scene& scene, const ClassTable& table) {
  std::ostringstream out;
  out << "# Property regions and route of scene '" << scene.name << "' (hazmap simulate --scene "
      << "scene.ply --regions regions.yaml reproduces it).\n";
  out << "regions:\n";
  for (const auto& r : scene.regions) {
    const ClassInfo* info = table.find(r.class_id);
    const std::string cls = info ? info->name : std::to_string(r.class_id);
    out << "  - {name: \"" << r.name << "\", class: " << cls << ", ";
    if (r.shape == PropertyRegion::Shape::Box) {
      out << "box: {min: " << point(r.box_min) << ", max: " << point(r.box_max) << "}}\n";
    } else {
      out << "polygon: [";
      for (std::size_t i = 0; i < r.polygon.size(); ++i) out << (i ? ", " : "") << point(r.polygon[i]);
      out << "], z: [" << num(r.z_min) << ", " << num(r.z_max) << "]}\n";
    }
  }
  if (scene.regions.empty()) out << "  []\n";
  out << "route:\n  waypoints: [";
  for (std::size_t i = 0; i < scene.route.waypoints.size(); ++i)
    out << (i ? ", " : "") << point(scene.route.waypoints[i]);
  out << "]\n  corner_radius: " << num(scene.route.corner_radius) << "\n  floor_z: "
      << num(scene.route.floor_z) << "\n  loop_waypoints: " << scene.route.loop_waypoints << "\n";
  return out.str();
}

}  // namespace hazmap::sim
