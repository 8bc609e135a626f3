// `vdbmap mesh MAP.vdb -o MESH.ply`: the surface of a saved map.
#include "command.hpp"

#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/map_file.hpp"
#include "vdbmap/mesh.hpp"

#include <cstdio>

namespace vdbmap::cli {
namespace {
const Registration registration("mesh", [](CLI::App& app) {
  auto map = std::make_shared<std::filesystem::path>();
  auto out = std::make_shared<std::filesystem::path>();
  CLI::App* sub = app.add_subcommand("mesh", "Extract the surface of a map (.vdb) as a PLY mesh");
  sub->add_option("map", *map, "Map written by `vdbmap integrate` (.vdb)")->required()->check(CLI::ExistingFile);
  sub->add_option("-o,--output", *out, "Mesh to write (.ply)")->required();
  sub->callback([map, out] {
    const TriangleMesh mesh = extractMesh(*readTsdfGrid(*map));
    io::writePlyMesh(*out, mesh);
    std::printf("wrote %s: %zu vertices, %zu triangles\n", out->c_str(), mesh.vertices.size(), mesh.triangles.size());
  });
});
}  // namespace
}  // namespace vdbmap::cli
