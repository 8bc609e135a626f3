// `vdbmap world office -o W.ply [--size X,Y] [--height H] [--seed N] ...`: writes a generated
// world mesh (sim/office_world.hpp) for `explore`, `simulate` and the benchmarks.
#include "command.hpp"

#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/sim/office_world.hpp"

#include <cstdio>

namespace vdbmap::cli {
namespace {

struct OfficeOptions {
  std::filesystem::path output;
  std::vector<double> size{sim::OfficeWorldConfig{}.size_x_m, sim::OfficeWorldConfig{}.size_y_m};
  sim::OfficeWorldConfig config;
};

void runOffice(const OfficeOptions& o) {
  sim::OfficeWorldConfig c = o.config;
  c.size_x_m = o.size[0];
  c.size_y_m = o.size[1];
  const sim::OfficeWorld w = sim::generateOffice(c);
  io::writePlyMesh(o.output, w.mesh);
  std::printf("%s: office %.1f x %.1f x %.1f m, seed %llu: %zu rooms, %zu doors, %zu pillars, %zu desks and cabinets, "
              "%zu triangles\n",
              o.output.c_str(), c.size_x_m, c.size_y_m, c.height_m, static_cast<unsigned long long>(c.seed),
              w.rooms.size(), w.doors, w.pillars, w.clutter, w.mesh.triangles.size());
}

const Registration registration("world", [](CLI::App& app) {
  CLI::App* world = app.add_subcommand("world", "Generate a world mesh for the simulator");
  world->require_subcommand(1);
  auto o = std::make_shared<OfficeOptions>();
  CLI::App* sub = world->add_subcommand(
      "office", "An office of rooms off a corridor, with doors (some between rooms), pillared halls, desks and "
                "cabinets; the same options give the same mesh");
  sub->option_defaults()->always_capture_default();
  sub->add_option("--size", o->size, "Length x and width y in metres")->delimiter(',')->expected(2);
  sub->add_option("--height", o->config.height_m, "Ceiling height in metres");
  sub->add_option("--seed", o->config.seed, "Layout seed");
  sub->add_option("--corridor-width", o->config.corridor_width_m, "Corridor width in metres");
  sub->add_option("--min-room", o->config.min_room_m, "Narrowest room along the corridor, metres");
  sub->add_option("--max-room", o->config.max_room_m, "Widest room along the corridor, metres");
  sub->add_option("--door-width", o->config.door_width_m, "Door width in metres");
  sub->add_option("--connect-probability", o->config.connect_probability,
                  "Probability of a door between neighbouring rooms");
  sub->add_option("--clutter", o->config.clutter_per_room, "Desks and cabinets tried per room");
  sub->add_option("-o,--output", o->output, "The mesh to write (.ply)")->required();
  sub->callback([o] { runOffice(*o); });
});

}  // namespace
}  // namespace vdbmap::cli
