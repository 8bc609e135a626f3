// Accuracy and completeness of a reconstructed surface against ground truth.
#include "binding.hpp"

#include "vdbmap/eval.hpp"

namespace vdbmap::python {
namespace {

/// Calls `distance` on every point (N, 3) with the GIL released; float64 (N,).
template <typename Fn>
py::array_t<double> distances(py::handle points, Fn&& distance) {
  const PointCloud p = toPoints(points, "points_W");
  py::array_t<double> out(py::ssize_t(p.size()));
  double* d = out.mutable_data();
  {
    py::gil_scoped_release nogil;
    for (std::size_t i = 0; i < p.size(); ++i) d[i] = distance(p[i].cast<double>());
  }
  return out;
}

void bindSurfaceDistance(py::module_& m) {
  py::class_<SurfaceDistance> s(m, "SurfaceDistance",
                                "Nearest-surface distance to a triangle mesh, or to a point cloud (a mesh "
                                "without triangles): a KD-tree over surface samples finds candidate triangles, "
                                "exact point-to-triangle distances decide.");
  s.def(py::init([](py::handle mesh, double sample_spacing_m) {
          const TriangleMesh tm = toMesh(mesh, "mesh");
          py::gil_scoped_release nogil;
          return SurfaceDistance(tm, sample_spacing_m);
        }),
        py::arg("mesh"), py::arg("sample_spacing_m"),
        "mesh: (vertices (V, 3), triangles (T, 3)); sample_spacing_m: spacing of the samples that index it.")
      .def(
          "distance",
          [](const SurfaceDistance& self, py::handle points_W) {
            return distances(points_W, [&](const Vec3d& p) { return self.distance(p); });
          },
          py::arg("points_W"), "Distances float64 (N,) of points (N, 3) to the surface.")
      .def(
          "vertex_distance",
          [](const SurfaceDistance& self, py::handle points_W) {
            return distances(points_W, [&](const Vec3d& p) { return self.vertexDistance(p); });
          },
          py::arg("points_W"), "Distances float64 (N,) to the nearest mesh vertex (nvblox's metric).")
      .def(
          "samples",
          [](const SurfaceDistance& self) {
            const std::vector<Vec3d>& v = self.samples();
            py::array_t<double> out({py::ssize_t(v.size()), py::ssize_t(3)});
            auto o = out.mutable_unchecked<2>();
            for (std::size_t i = 0; i < v.size(); ++i)
              for (int k = 0; k < 3; ++k) o(py::ssize_t(i), k) = v[i][k];
            return out;
          },
          "The area-weighted surface samples (seeded, deterministic), float64 (S, 3).");
}

void bindEvaluation(py::module_& m) {
  py::class_<SurfaceEval> e(m, "SurfaceEval",
                            "Accuracy (distances of the reconstruction to ground truth) and "
                            "completeness (ground truth within the threshold of the reconstruction).");
  e.def_readonly("reconstructed_vertices", &SurfaceEval::reconstructed_vertices, "vertices whose distance was measured")
      .def_readonly("ground_truth_samples", &SurfaceEval::ground_truth_samples, "samples of the ground-truth surface")
      .def_readonly("accuracy_rmse_m", &SurfaceEval::accuracy_rmse_m, "the paper's metric")
      .def_readonly("accuracy_mean_m", &SurfaceEval::accuracy_mean_m, "mean vertex distance")
      .def_readonly("accuracy_median_m", &SurfaceEval::accuracy_median_m, "median vertex distance")
      .def_readonly("accuracy_vertex_to_vertex_mean_m", &SurfaceEval::accuracy_vertex_to_vertex_mean_m,
                    "nvblox's metric: nearest ground-truth vertex")
      .def_readonly("completeness", &SurfaceEval::completeness, "fraction in [0, 1]")
      .def_readonly("completeness_threshold_m", &SurfaceEval::completeness_threshold_m, "the threshold used")
      .def("__repr__", [](py::handle self) { return reprOfProperties(self); });

  m.def(
      "evaluate_surface",
      [](py::handle reconstruction, py::handle ground_truth, const EvalConfig& config) {
        const TriangleMesh r = toMesh(reconstruction, "reconstruction");
        const TriangleMesh g = toMesh(ground_truth, "ground_truth");
        py::gil_scoped_release nogil;
        return evaluateSurface(r, g, config);
      },
      py::arg("reconstruction"), py::arg("ground_truth"), py::arg("config") = EvalConfig{},
      "Compares a reconstruction (e.g. extract_mesh(volume)) with a ground-truth mesh or point cloud, each a "
      "(vertices, triangles) pair. ValueError when either is empty.");
}

void bindEval(py::module_& m) {
  bindSurfaceDistance(m);
  bindEvaluation(m);
}

const BindRegistration registration(kBindEval, "eval", &bindEval);

}  // namespace
}  // namespace vdbmap::python
