// Generated office worlds: rooms off a corridor, doors, pillars and clutter, from a size and a
// seed. For planners and active loop closure, one layout is an anecdote; a generator gives as
// many layouts as needed, with seeds kept apart for tuning and for reporting.
//
// Layout (x along the length, y across, z up, the floor at z = 0 over [0, size_x] x [0, size_y]):
// a corridor along x at a random offset from the middle; on each side a strip split along x into
// rooms of random widths; every room has a door to the corridor, and neighbouring rooms a door
// between them with probability `connect_probability` (loops that a vehicle can fly around); the
// widest room of each strip may be an open hall with pillars; rooms hold desks and cabinets
// against their walls, kept clear of the doors. Walls are boxes of `wall_thickness_m`, doors are
// openings of `door_width_m` up to `door_height_m` (a lintel above), the ceiling is a slab at
// `height_m`. Every room is reachable from the corridor by a vehicle keeping
// (door_width_m - wall_thickness_m) / 2 from surfaces.
#pragma once

#include "vdbmap/triangle_mesh.hpp"
#include "vdbmap/types.hpp"

#include <Eigen/Geometry>

#include <cstdint>
#include <vector>

namespace vdbmap::sim {

struct OfficeWorldConfig {
  double size_x_m = 30.0;            ///< [8, 500]
  double size_y_m = 16.0;            ///< at least corridor + 2 x min_room_m
  double height_m = 3.0;             ///< ceiling height; [door_height_m + 0.2, 20]
  double corridor_width_m = 2.2;     ///< [1.2, 10]
  double min_room_m = 3.5;           ///< smallest room width along x; [2.5, 50]
  double max_room_m = 7.0;           ///< largest; [min_room_m, 100]
  double door_width_m = 1.1;         ///< [0.8, 3]
  double door_height_m = 2.1;        ///< [1.5, 5]
  double wall_thickness_m = 0.15;    ///< [0.05, 1]
  double connect_probability = 0.5;  ///< a door between neighbouring rooms; [0, 1]
  double hall_probability = 0.5;     ///< the widest room of a strip becomes a pillared hall; [0, 1]
  double pillar_size_m = 0.4;        ///< square pillars; [0.1, 2]
  int clutter_per_room = 3;          ///< desks and cabinets tried per room; [0, 20]
  std::uint64_t seed = 1;

  void validate() const;
};

struct OfficeWorld {
  TriangleMesh mesh;
  std::vector<Eigen::AlignedBox3d> rooms;  ///< interiors (inside the walls), floor to ceiling
  Eigen::AlignedBox3d corridor;            ///< its interior
  std::size_t doors = 0;
  std::size_t pillars = 0;
  std::size_t clutter = 0;                 ///< desks and cabinets placed
};

/// The office for `config` (the same config gives the same mesh). Throws std::invalid_argument
/// for an invalid config.
OfficeWorld generateOffice(const OfficeWorldConfig& config);

}  // namespace vdbmap::sim
