// The built-in scenes. Coordinates in metres, z up, floor at z = 0. Layout of `naraha`
// (top view, x to the right, y up; hall interior [0, 40] x [0, 24], route drawn with dots):
//
//   y=24 +----------------------------------------+
//        | . . . . . .                . . . . . . |   y=22  route
//        | .  H3    . T   T   T   T*  T . T     . |   y=19  tanks, x = 11, 15, ..., 31
//        | .     P  .   P    W2   P     .   P   . |   y=16  pillars, x = 8, 16, 24, 32
//        | .        . . . . . . . . . . .       . |   y=13  route
//        | .     P  [stairs A] P    P  [stairs B]P. |   y=8   pillars; stairs x 10.5, 26.5
//        | .                               W3     . |
//        | S . .=[==== corridor H1  W1 ====]= . . . |   y=2.5 route; corridor x 10..30, y 1..4
//   y=0  +----------------------------------------+
//
// S = start (5, 2.5), heading east. T = tank (Ø 2 m, 3 m), P = 0.6 m pillar, H = heat source,
// W = puddle, T* = tank with a heat patch on its south face.
#include <algorithm>
#include <cmath>

#include "hazmap/core/error.hpp"
#include "hazmap/sim/mesh_builder.hpp"
#include "hazmap/sim/scene.hpp"

namespace hazmap::sim {

namespace {

constexpr ClassId kHeat = 1;
constexpr ClassId kWater = 2;

using V2 = Eigen::Vector2d;
using V3 = Eigen::Vector3d;

/// A heat source that is a box standing on / fixed to a surface: geometry plus a region 5 cm
/// larger, so the surface right around it is warm too.
void heatBox(Scene& s, MeshBuilder& mb, const std::string& name, const V3& lo, const V3& hi) {
  mb.box(lo, hi);
  const V3 margin = V3::Constant(0.05);
  s.regions.push_back(PropertyRegion::box(name, kHeat, lo - margin, hi + margin));
}

/// A puddle: a floor decal 3 mm above the floor (so scene.ply shows it) and a thin prism region.
void puddle(Scene& s, MeshBuilder& mb, const std::string& name, const std::vector<V2>& polygon) {
  mb.polygonDecal(polygon, 0.003);
  s.regions.push_back(PropertyRegion::prism(name, kWater, polygon, -0.05, 0.05));
}

/// Four walls of a hall with interior [0, sx] x [0, sy], `height` high, 0.3 m thick.
void hallWalls(MeshBuilder& mb, double sx, double sy, double height) {
  const double t = 0.3;
  mb.box({-t, -t, 0}, {sx + t, 0, height});
  mb.box({-t, sy, 0}, {sx + t, sy + t, height});
  mb.box({-t, 0, 0}, {0, sy, height});
  mb.box({sx, 0, 0}, {sx + t, sy, height});
}

Scene naraha() {
  Scene s;
  s.name = "naraha";
  MeshBuilder mb(s.mesh);
  const double hall_x = 40.0, hall_y = 24.0, wall_h = 5.0;
  mb.floorRect(-0.3, -0.3, hall_x + 0.3, hall_y + 0.3, 0.0);
  hallWalls(mb, hall_x, hall_y, wall_h);

  // Featureless corridor: interior x 10..30, y 1..4, 3 m high with a ceiling; open ends.
  mb.box({10, 0.8, 0}, {30, 1.0, 3.0});
  mb.box({10, 4.0, 0}, {30, 4.2, 3.0});
  mb.box({10, 0.8, 3.0}, {30, 4.2, 3.2});

  // Six identical water tanks, Ø 2 m, 3 m high, 4 m apart.
  for (int k = 0; k < 6; ++k) mb.cylinder(V2(11.0 + 4.0 * k, 19.0), 1.0, 0.0, 3.0);

  // Pillars 0.6 m square every 8 m, up to the wall height.
  for (double x : {8.0, 16.0, 24.0, 32.0})
    for (double y : {8.0, 16.0}) mb.box({x - 0.3, y - 0.3, 0}, {x + 0.3, y + 0.3, wall_h});

  // Two identical mock-up staircases (6 steps of 0.25 m x 0.4 m, 2 m wide, 1.5 m landing).
  for (double x : {10.5, 26.5}) mb.staircase({x, 6.5, 0.0}, 6, 0.25, 0.4, 2.0, 1.5);

  // Heat sources: a heater panel on the corridor's north wall (off-centre), a hot patch on the
  // south face of the fourth tank, a hot machine near the west wall.
  heatBox(s, mb, "heat_corridor_panel", {17.0, 3.88, 0.3}, {18.2, 4.0, 1.3});
  s.regions.push_back(PropertyRegion::box("heat_tank_patch", kHeat, {22.3, 17.8, 0.6}, {23.7, 18.6, 2.2}));
  heatBox(s, mb, "heat_machine", {5.0, 15.0, 0.0}, {6.0, 16.0, 1.2});

  // Puddles: irregular floor patches 1-3 m across.
  puddle(s, mb, "water_corridor",
         {{21.6, 1.7}, {22.4, 1.5}, {23.3, 1.8}, {23.6, 2.5}, {23.0, 3.1}, {22.1, 3.0}, {21.5, 2.5}});
  puddle(s, mb, "water_tanks",
         {{19.2, 16.3}, {20.4, 16.1}, {21.3, 16.6}, {21.0, 17.5}, {20.0, 17.7}, {19.3, 17.2}});
  puddle(s, mb, "water_east",
         {{32.2, 5.3}, {33.5, 5.0}, {34.3, 5.8}, {34.0, 6.9}, {33.1, 7.2}, {32.5, 6.6}});

  // Closed loop (~120 m): east through the corridor, north, west along the tanks' north side,
  // south through the gap between tanks 5 and 6, west along their south side, north through the
  // gap between tanks 1 and 2, west, south along the west wall, back to the start heading east.
  // Then the corridor is driven again (20 m) so that loops can be closed.
  s.route.waypoints = {{5, 2.5},  {37, 2.5}, {37, 22}, {29, 22}, {29, 13}, {13, 13},
                       {13, 22},  {3, 22},   {3, 2.5}, {5, 2.5}, {25, 2.5}};
  s.route.loop_waypoints = 10;
  s.route.corner_radius = 2.0;
  return s;
}

Scene corridor() {
  Scene s;
  s.name = "corridor";
  MeshBuilder mb(s.mesh);
  // 60 m x 3 m corridor, 3 m high, ceiling; open ends, the floor runs on 20 m beyond them.
  mb.floorRect(-20, -1.7, 80, 1.7, 0.0);
  mb.box({0, -1.7, 0}, {60, -1.5, 3.0});
  mb.box({0, 1.5, 0}, {60, 1.7, 3.0});
  mb.box({0, -1.7, 3.0}, {60, 1.7, 3.2});
  heatBox(s, mb, "heat_panel_north", {18.0, 1.38, 0.4}, {19.2, 1.5, 1.4});
  heatBox(s, mb, "heat_panel_south", {41.0, -1.5, 0.2}, {41.8, -1.38, 0.9});
  puddle(s, mb, "water_a", {{29.8, -0.9}, {31.1, -1.1}, {31.6, -0.2}, {31.0, 0.6}, {30.1, 0.3}});
  puddle(s, mb, "water_b", {{47.5, 0.1}, {48.6, -0.2}, {49.1, 0.7}, {48.2, 1.2}, {47.6, 0.9}});
  // Out along the axis, turn on the spot, back to the start.
  s.route.waypoints = {{5, 0}, {55, 0}, {5, 0}};
  s.route.corner_radius = 0.0;
  return s;
}

Scene tanks() {
  Scene s;
  s.name = "tanks";
  MeshBuilder mb(s.mesh);
  // An open field: floor only, twelve identical tanks on a 4 m grid (4 x 3).
  mb.floorRect(-30, -30, 42, 38, 0.0);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 3; ++j) mb.cylinder(V2(4.0 * i, 4.0 * j), 1.0, 0.0, 3.0);
  s.regions.push_back(PropertyRegion::box("heat_tank_patch", kHeat, {3.3, 0.8, 0.5}, {4.7, 1.6, 2.0}));
  heatBox(s, mb, "heat_box", {13.6, 9.0, 0.0}, {14.4, 9.8, 1.0});
  puddle(s, mb, "water", {{5.6, 5.4}, {6.7, 5.2}, {7.0, 6.3}, {6.1, 6.8}, {5.5, 6.2}});
  // A loop around the field, then its first side again.
  s.route.waypoints = {{-4, -4}, {16, -4}, {16, 12}, {-4, 12}, {-4, -4}, {16, -4}};
  s.route.loop_waypoints = 5;
  s.route.corner_radius = 2.0;
  return s;
}

}  // namespace

std::vector<std::string> builtinSceneNames() { return {"naraha", "corridor", "tanks"}; }

Scene builtinScene(const std::string& name) {
  Scene s;
  if (name == "naraha")
    s = naraha();
  else if (name == "corridor")
    s = corridor();
  else if (name == "tanks")
    s = tanks();
  else
    fail("scenario", "unknown scenario '" + name + "' (known: naraha, corridor, tanks)");
  s.labelTriangles();
  return s;
}

}  // namespace hazmap::sim
