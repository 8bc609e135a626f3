#include "vdbmap/sim/office_world.hpp"
#include "vdbmap/field_check.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>

namespace vdbmap::sim {
namespace {

/// An axis-aligned box's six faces, outward (counter-clockwise seen from outside).
void appendBox(TriangleMesh& m, const Vec3d& lo, const Vec3d& hi) {
  const int base = int(m.vertices.size());
  for (int k = 0; k < 8; ++k)
    m.vertices.emplace_back(float(k & 1 ? hi.x() : lo.x()), float(k & 2 ? hi.y() : lo.y()), float(k & 4 ? hi.z() : lo.z()));
  static const int quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (const auto& q : quads) {
    m.triangles.emplace_back(base + q[0], base + q[1], base + q[2]);
    m.triangles.emplace_back(base + q[0], base + q[2], base + q[3]);
  }
}

struct Interval {
  double lo, hi;
};

class Builder {
 public:
  explicit Builder(const OfficeWorldConfig& c) : c_(c) {}

  /// A wall along `axis` (0: x, 1: y) from `from` to `to`, its thickness spanning [across_lo,
  /// across_hi] on the other axis, full height, with door openings (and lintels above them).
  void wall(int axis, double across_lo, double across_hi, double from, double to, std::vector<Interval> doors) {
    std::sort(doors.begin(), doors.end(), [](const Interval& a, const Interval& b) { return a.lo < b.lo; });
    double at = from;
    const auto piece = [&](double a, double b, double z0, double z1) {
      if (b - a < 1e-6) return;
      Vec3d lo, hi;
      lo[axis] = a;
      hi[axis] = b;
      lo[1 - axis] = across_lo;
      hi[1 - axis] = across_hi;
      lo.z() = z0;
      hi.z() = z1;
      appendBox(out.mesh, lo, hi);
    };
    for (const Interval& d : doors) {
      piece(at, d.lo, 0.0, c_.height_m);
      piece(d.lo, d.hi, c_.door_height_m, c_.height_m);
      at = d.hi;
      ++out.doors;
    }
    piece(at, to, 0.0, c_.height_m);
  }

  OfficeWorld out;

 private:
  const OfficeWorldConfig& c_;
};

/// Room boundaries along x over [0, length]: widths in [min, max] (one narrower or wider room at
/// the end when the rest cannot be split so).
std::vector<double> splitRooms(double length, double min, double max, std::mt19937_64& rng) {
  std::vector<double> cuts{0.0};
  double x = 0.0;
  while (length - x > max) {
    double w = std::uniform_real_distribution<double>(min, max)(rng);
    if (length - x - w < min) w = length - x - min;
    if (w < min) break;
    x += w;
    cuts.push_back(x);
  }
  cuts.push_back(length);
  return cuts;
}

}  // namespace

void OfficeWorldConfig::validate() const {
  const FieldCheck check("OfficeWorldConfig");
  check.inRange("size_x_m", size_x_m, 8.0, 500.0);
  check.inRange("door_height_m", door_height_m, 1.5, 5.0);
  check.inRange("height_m", height_m, door_height_m + 0.2, 20.0);
  check.inRange("corridor_width_m", corridor_width_m, 1.2, 10.0);
  check.inRange("min_room_m", min_room_m, 2.5, 50.0);
  check.inRange("max_room_m", max_room_m, min_room_m, 100.0);
  check.inRange("door_width_m", door_width_m, 0.8, 3.0);
  check.inRange("wall_thickness_m", wall_thickness_m, 0.05, 1.0);
  check.inRange("size_y_m", size_y_m, corridor_width_m + 2.0 * (min_room_m + wall_thickness_m) + 1.0, 500.0);
  check.inRange("connect_probability", connect_probability, 0.0, 1.0);
  check.inRange("hall_probability", hall_probability, 0.0, 1.0);
  check.inRange("pillar_size_m", pillar_size_m, 0.1, 2.0);
  check.inRange("clutter_per_room", double(clutter_per_room), 0.0, 20.0);
  if (door_width_m + 1.0 > min_room_m - wall_thickness_m)
    throw std::invalid_argument("OfficeWorldConfig: door_width_m + 1 m must fit in a room (min_room_m - wall_thickness_m)");
}

OfficeWorld generateOffice(const OfficeWorldConfig& c) {
  c.validate();
  std::mt19937_64 rng(c.seed);
  const auto uniform = [&rng](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  const double L = c.size_x_m, W = c.size_y_m, H = c.height_m, t = c.wall_thickness_m, dw = c.door_width_m;
  Builder b(c);
  OfficeWorld& out = b.out;

  // Shell: floor, ceiling, outer walls.
  appendBox(out.mesh, Vec3d(-t, -t, -0.1), Vec3d(L + t, W + t, 0.0));
  appendBox(out.mesh, Vec3d(-t, -t, H), Vec3d(L + t, W + t, H + 0.1));
  appendBox(out.mesh, Vec3d(-t, -t, 0.0), Vec3d(0.0, W + t, H));
  appendBox(out.mesh, Vec3d(L, -t, 0.0), Vec3d(L + t, W + t, H));
  appendBox(out.mesh, Vec3d(0.0, -t, 0.0), Vec3d(L, 0.0, H));
  appendBox(out.mesh, Vec3d(0.0, W, 0.0), Vec3d(L, W + t, H));

  // The corridor [y0, y1] (interior), off the middle by up to a quarter of the spare width.
  const double spare = W - c.corridor_width_m - 2.0 * (c.min_room_m + t);
  const double y0 = (W - c.corridor_width_m) / 2.0 + uniform(-0.25, 0.25) * spare;
  const double y1 = y0 + c.corridor_width_m;
  out.corridor = Eigen::AlignedBox3d(Vec3d(0.0, y0, 0.0), Vec3d(L, y1, H));

  struct Strip {
    double room_y0, room_y1;      ///< the rooms' interior across
    double wall_lo, wall_hi;      ///< the corridor wall's thickness
  };
  const Strip strips[2] = {{0.0, y0 - t, y0 - t, y0}, {y1 + t, W, y1, y1 + t}};
  std::vector<Eigen::AlignedBox3d> obstacles;  // pillars and clutter placed so far (footprints)
  for (const Strip& s : strips) {
    const std::vector<double> cuts = splitRooms(L, c.min_room_m, c.max_room_m, rng);
    std::vector<Interval> corridor_doors;
    std::size_t widest = 0;
    for (std::size_t r = 0; r + 1 < cuts.size(); ++r)
      if (cuts[r + 1] - cuts[r] > cuts[widest + 1] - cuts[widest]) widest = r;
    const bool hall = uniform(0.0, 1.0) < c.hall_probability;
    std::optional<Vec3d> previous_partition_door;
    for (std::size_t r = 0; r + 1 < cuts.size(); ++r) {
      const double x0 = r == 0 ? 0.0 : cuts[r] + t / 2.0, x1 = r + 2 == cuts.size() ? L : cuts[r + 1] - t / 2.0;
      const Eigen::AlignedBox3d room(Vec3d(x0, s.room_y0, 0.0), Vec3d(x1, s.room_y1, H));
      out.rooms.push_back(room);
      std::vector<Vec3d> door_centres;
      if (previous_partition_door) door_centres.push_back(*previous_partition_door);  // from this side too
      previous_partition_door.reset();
      const double dx = uniform(x0 + 0.5, x1 - 0.5 - dw);
      corridor_doors.push_back({dx, dx + dw});
      door_centres.emplace_back(dx + dw / 2.0, s.wall_lo < y0 ? s.room_y1 : s.room_y0, 0.0);
      if (r + 2 < cuts.size()) {  // the partition to the next room, maybe with a door
        std::vector<Interval> doors;
        if (uniform(0.0, 1.0) < c.connect_probability) {
          const double dy = uniform(s.room_y0 + 0.5, s.room_y1 - 0.5 - dw);
          doors.push_back({dy, dy + dw});
          door_centres.emplace_back(x1, dy + dw / 2.0, 0.0);
          previous_partition_door = Vec3d(cuts[r + 1] + t / 2.0, dy + dw / 2.0, 0.0);
        }
        b.wall(1, cuts[r + 1] - t / 2.0, cuts[r + 1] + t / 2.0, s.room_y0, s.room_y1, doors);
      }
      // A pillared hall: a grid of pillars kept 1.3 m from the walls.
      if (hall && r == widest) {
        const double margin = 1.3, spacing = uniform(2.6, 3.4);
        for (double px = x0 + margin; px <= x1 - margin; px += spacing)
          for (double py = s.room_y0 + margin; py <= s.room_y1 - margin; py += spacing) {
            const Vec3d lo(px - c.pillar_size_m / 2, py - c.pillar_size_m / 2, 0.0);
            const Vec3d hi(px + c.pillar_size_m / 2, py + c.pillar_size_m / 2, H);
            appendBox(out.mesh, lo, hi);
            obstacles.emplace_back(lo, hi);
            ++out.pillars;
          }
      }
      // Desks and cabinets against the walls, clear of doors and of each other.
      for (int k = 0; k < c.clutter_per_room; ++k) {
        const bool desk = uniform(0.0, 1.0) < 0.6;
        const double along = desk ? uniform(1.2, 1.6) : uniform(0.8, 1.2);
        const double depth = desk ? uniform(0.6, 0.8) : uniform(0.4, 0.5);
        const double height = desk ? uniform(0.72, 0.78) : uniform(1.6, 2.0);
        const int side = int(uniform(0.0, 4.0));  // 0: y low, 1: y high, 2: x low, 3: x high
        Vec3d lo, hi;
        if (side < 2) {
          if (x1 - x0 < along + 0.2) continue;
          const double a = uniform(x0 + 0.1, x1 - 0.1 - along);
          lo = Vec3d(a, side == 0 ? s.room_y0 : s.room_y1 - depth, 0.0);
          hi = Vec3d(a + along, side == 0 ? s.room_y0 + depth : s.room_y1, height);
        } else {
          if (s.room_y1 - s.room_y0 < along + 0.2) continue;
          const double a = uniform(s.room_y0 + 0.1, s.room_y1 - 0.1 - along);
          lo = Vec3d(side == 2 ? x0 : x1 - depth, a, 0.0);
          hi = Vec3d(side == 2 ? x0 + depth : x1, a + along, height);
        }
        const Eigen::AlignedBox3d box(lo, hi);
        bool clear = true;
        for (const Vec3d& d : door_centres) {
          const Vec3d nearest = d.cwiseMax(lo).cwiseMin(hi);
          if ((nearest - d).head<2>().norm() < 1.4) clear = false;
        }
        for (const Eigen::AlignedBox3d& o : obstacles) {
          Eigen::AlignedBox3d grown = o;
          grown.extend(o.min() - Vec3d(0.8, 0.8, 0.0)).extend(o.max() + Vec3d(0.8, 0.8, 0.0));
          if (grown.intersects(box)) clear = false;
        }
        if (!clear) continue;
        appendBox(out.mesh, lo, hi);
        obstacles.push_back(box);
        ++out.clutter;
      }
    }
    b.wall(0, s.wall_lo, s.wall_hi, 0.0, L, corridor_doors);
  }
  return std::move(out);
}

}  // namespace vdbmap::sim
