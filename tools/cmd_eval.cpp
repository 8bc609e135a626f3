// `vdbmap eval MAP.vdb --gt GT.ply [--json OUT.json]`: accuracy and completeness of a map.
#include "cli_util.hpp"
#include "command.hpp"

#include "vdbmap/eval.hpp"
#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/map_file.hpp"
#include "vdbmap/mesh.hpp"

#include <cstdio>

namespace vdbmap::cli {
namespace {

struct EvalOptions {
  std::filesystem::path map, gt, json;
  double threshold_vox = 2.0;
  double spacing_m = EvalConfig{}.sample_spacing_m;
};

const Registration registration("eval", [](CLI::App& app) {
  auto o = std::make_shared<EvalOptions>();
  CLI::App* sub = app.add_subcommand(
      "eval", "Accuracy (RMSE, mean, median distance of the map's surface to ground truth) and completeness "
              "(fraction of the ground-truth surface within a threshold of the map)");
  sub->option_defaults()->always_capture_default();
  sub->add_option("map", o->map, "Map file (.vdb)")->required()->check(CLI::ExistingFile);
  sub->add_option("--gt", o->gt, "Ground truth: triangle mesh (PLY, OBJ, OFF) or point cloud (PLY)")
      ->required()->check(CLI::ExistingFile);
  sub->add_option("--threshold-vox", o->threshold_vox, "Completeness threshold in voxels")->check(CLI::PositiveNumber);
  sub->add_option("--sample-spacing", o->spacing_m, "Ground-truth surface sampling in metres")->check(CLI::PositiveNumber);
  sub->add_option("--json", o->json, "Write the result as JSON");
  sub->callback([o] {
    const openvdb::FloatGrid::Ptr tsdf = readTsdfGrid(o->map);
    const TriangleMesh mesh = extractMesh(*tsdf);
    if (mesh.vertices.empty()) throw std::runtime_error(o->map.string() + ": the map has no surface to evaluate");
    const TriangleMesh gt = io::readTriangleMesh(o->gt);
    EvalConfig config;
    config.completeness_threshold_m = o->threshold_vox * tsdf->voxelSize()[0];
    config.sample_spacing_m = o->spacing_m;
    const SurfaceEval e = evaluateSurface(mesh, gt, config);
    const nlohmann::json j = {{"map", o->map.string()},
                              {"ground_truth", o->gt.string()},
                              {"voxel_size_m", tsdf->voxelSize()[0]},
                              {"reconstructed_vertices", e.reconstructed_vertices},
                              {"ground_truth_samples", e.ground_truth_samples},
                              {"accuracy_rmse_m", e.accuracy_rmse_m},
                              {"accuracy_mean_m", e.accuracy_mean_m},
                              {"accuracy_median_m", e.accuracy_median_m},
                              {"accuracy_vertex_to_vertex_mean_m", e.accuracy_vertex_to_vertex_mean_m},
                              {"completeness", e.completeness},
                              {"completeness_threshold_m", e.completeness_threshold_m}};
    if (!o->json.empty()) writeJson(o->json, j);
    std::printf("accuracy: rmse %.4f m, mean %.4f m, median %.4f m (vertex-to-vertex mean %.4f m) over %zu vertices\n",
                e.accuracy_rmse_m, e.accuracy_mean_m, e.accuracy_median_m, e.accuracy_vertex_to_vertex_mean_m,
                e.reconstructed_vertices);
    std::printf("completeness: %.3f of the ground-truth surface within %.3f m\n", e.completeness,
                e.completeness_threshold_m);
  });
});

}  // namespace
}  // namespace vdbmap::cli
