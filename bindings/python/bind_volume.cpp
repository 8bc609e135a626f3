// TsdfVolume: integration, exact de-integration, queries at arrays of points, exports, files; and
// mesh extraction.
#include "binding.hpp"
#include "object_lock.hpp"

#include "vdbmap/mesh.hpp"
#include "vdbmap/tsdf_volume.hpp"

namespace vdbmap::python {
namespace {

void bindIntegrationStats(py::module_& m) {
  py::class_<IntegrationStats> s(m, "IntegrationStats", "What one integrate() or deintegrate() did with its points.");
  s.def_readonly("points_total", &IntegrationStats::points_total, "points given")
      .def_readonly("points_invalid", &IntegrationStats::points_invalid,
                    "NaN, infinite, zero, or closer than min_range_m")
      .def_readonly("points_beyond_range", &IntegrationStats::points_beyond_range,
                    "beyond max_range_m: carved free space only")
      .def_readonly("rays_cast", &IntegrationStats::rays_cast, "after bundling (Merged) or one per valid point")
      .def_readonly("voxel_updates", &IntegrationStats::voxel_updates, "voxel visits summed over all rays")
      .def_property_readonly(
          "touched_voxels", [](const IntegrationStats& s) { return toTuple(s.touched_voxels); },
          "index-space box ((i, j, k) min, (i, j, k) max) around every voxel touched, or None")
      .def("__repr__", [](py::handle self) { return reprOfProperties(self); });
}

/// (tsdf_m float32 (N,), weight float32 (N,), state uint8 (N,)) for the given voxels.
py::tuple samples(const TsdfVolume& v, const std::vector<openvdb::Coord>& voxels) {
  const py::ssize_t n = py::ssize_t(voxels.size());
  py::array_t<float> tsdf(n), weight(n);
  py::array_t<std::uint8_t> state(n);
  float* t = tsdf.mutable_data();
  float* w = weight.mutable_data();
  std::uint8_t* s = state.mutable_data();
  withLock(&v, Access::Read, [&] {
    for (std::size_t i = 0; i < voxels.size(); ++i) {
      const VoxelSample sample = v.sample(voxels[i]);
      t[i] = sample.tsdf_m;
      w[i] = sample.weight;
      s[i] = std::uint8_t(sample.state);
    }
    return 0;
  });
  return py::make_tuple(tsdf, weight, state);
}

std::vector<openvdb::Coord> voxelsOf(const TsdfVolume& v, py::handle points_W) {
  const PointCloud p = toPoints(points_W, "points_W");
  std::vector<openvdb::Coord> voxels(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) voxels[i] = v.worldToVoxel(p[i].cast<double>());
  return voxels;
}

py::array_t<std::int32_t> coordsToArray(const std::vector<openvdb::Coord>& coords) {
  py::array_t<std::int32_t> out({py::ssize_t(coords.size()), py::ssize_t(3)});
  auto o = out.mutable_unchecked<2>();
  for (std::size_t i = 0; i < coords.size(); ++i)
    for (int k = 0; k < 3; ++k) o(py::ssize_t(i), k) = coords[i][k];
  return out;
}

/// Every known voxel (the tsdf grid's active voxels) with its tsdf and weight, in tree order.
py::tuple knownVoxels(const TsdfVolume& v) {
  std::vector<openvdb::Coord> ijk;
  std::vector<float> tsdf, weight;
  withLock(&v, Access::Read, [&] {
    const openvdb::FloatGrid::Ptr t = v.tsdfGrid();
    const openvdb::FloatGrid::Ptr w = v.weightGrid();
    const auto wacc = w->getConstAccessor();
    const std::size_t n = t->activeVoxelCount();
    ijk.reserve(n);
    tsdf.reserve(n);
    weight.reserve(n);
    for (auto it = t->cbeginValueOn(); it; ++it) {
      ijk.push_back(it.getCoord());
      tsdf.push_back(*it);
      weight.push_back(wacc.getValue(it.getCoord()));
    }
    return 0;
  });
  return py::make_tuple(coordsToArray(ijk), py::array_t<float>(py::ssize_t(tsdf.size()), tsdf.data()),
                        py::array_t<float>(py::ssize_t(weight.size()), weight.data()));
}

void bindTsdfVolume(py::module_& m) {
  py::class_<TsdfVolume> v(m, "TsdfVolume",
                           "The TSDF map: OpenVDB grids of exact 64-bit fixed-point sums. Integrating a frame and "
                           "de-integrating it restores every voxel bit for bit; frame order and thread count do "
                           "not change the map. Voxel (i, j, k) is centred at (i, j, k) * voxel_size_m. Copies "
                           "(copy.copy, copy.deepcopy) are deep.");
  v.def(py::init<const TsdfConfig&, const IntegratorConfig&>(), py::arg("config") = TsdfConfig{},
        py::arg("integrator") = IntegratorConfig{}, "An empty map; ValueError when a config field is out of range.")
      .def_property_readonly(
          "config", [](const TsdfVolume& self) { return self.config(); }, "TsdfConfig (a copy)")
      .def_property_readonly(
          "integrator_config", locked<Access::Read>(&TsdfVolume::integratorConfig),
          "IntegratorConfig (a copy)")
      .def("set_threads", locked<Access::Write>(&TsdfVolume::setThreads), py::arg("threads"),
           "Changes only the worker thread count (0 = all cores); the map does not depend on it.");

  v.def(
       "integrate",
       [](TsdfVolume& self, FrameId id, py::handle points_S, py::handle T_W_S) {
         const PointCloud p = toPoints(points_S, "points_S");
         const Pose3d T = toPose(T_W_S, "T_W_S");
         return withLock(&self, Access::Write, [&] { return self.integrate(id, p, T); });
       },
       py::arg("frame_id"), py::arg("points_S"), py::arg("T_W_S"),
       "Integrates points (N, 3) in the sensor frame seen from the pose T_W_S (4, 4). NaN/zero points are "
       "skipped and counted. ValueError, changing nothing, when frame_id is already integrated or the pose "
       "is not a rigid transform.")
      .def(
          "deintegrate",
          [](TsdfVolume& self, FrameId id, py::handle points_S, py::handle T_W_S) {
            const PointCloud p = toPoints(points_S, "points_S");
            const Pose3d T = toPose(T_W_S, "T_W_S");
            return withLock(&self, Access::Write, [&] { return self.deintegrate(id, p, T); });
          },
          py::arg("frame_id"), py::arg("points_S"), py::arg("T_W_S"),
          "Removes exactly what integrate(frame_id, points_S, T_W_S) added. ValueError, changing nothing, when "
          "the frame was never integrated or was integrated with other points or pose.")
      .def(
          "integrate_depth",
          [](TsdfVolume& self, FrameId id, py::handle depth, const CameraIntrinsics& K, py::handle T_W_S,
             std::optional<double> depth_scale) {
            const DepthImage d = toDepth(depth, depth_scale, "depth");
            const Pose3d T = toPose(T_W_S, "T_W_S");
            return withLock(&self, Access::Write, [&] { return self.integrate(id, d, K, T); });
          },
          py::arg("frame_id"), py::arg("depth"), py::arg("intrinsics"), py::arg("T_W_S"),
          py::arg("depth_scale") = py::none(),
          "Integrates a depth image (H, W): float metres, or uint16 raw units with depth_scale metres per unit. "
          "With ray_mode projective (the default) voxel by voxel; otherwise as integrate(frame_id, "
          "back_project(depth, intrinsics), T_W_S).")
      .def(
          "deintegrate_depth",
          [](TsdfVolume& self, FrameId id, py::handle depth, const CameraIntrinsics& K, py::handle T_W_S,
             std::optional<double> depth_scale) {
            const DepthImage d = toDepth(depth, depth_scale, "depth");
            const Pose3d T = toPose(T_W_S, "T_W_S");
            return withLock(&self, Access::Write, [&] { return self.deintegrate(id, d, K, T); });
          },
          py::arg("frame_id"), py::arg("depth"), py::arg("intrinsics"), py::arg("T_W_S"),
          py::arg("depth_scale") = py::none(), "The inverse of integrate_depth with the same arguments.")
      .def("is_integrated", locked<Access::Read>(&TsdfVolume::isIntegrated), py::arg("frame_id"),
           "Whether the map holds that frame.")
      .def_property_readonly("frame_count", locked<Access::Read>(&TsdfVolume::frameCount), "number of integrated frames")
      .def(
          "integrated_poses",
          [](const TsdfVolume& self) { return toDict(withLock(&self, Access::Read, [&] { return self.integratedPoses(); })); },
          "{frame_id: (4, 4) pose each frame was integrated with}");

  v.def(
       "sample", [](const TsdfVolume& self, py::handle points_W) { return samples(self, voxelsOf(self, points_W)); },
       py::arg("points_W"),
       "The voxels nearest to points (N, 3) in the world: (tsdf_m float32 (N,), weight float32 (N,), state "
       "uint8 (N,) with VoxelState values). Unknown voxels read tsdf = +truncation, weight 0.")
      .def(
          "sample_voxels", [](const TsdfVolume& self, py::handle ijk) { return samples(self, toCoords(ijk, "ijk")); },
          py::arg("ijk"), "Like sample() at voxel indices (N, 3) integers.")
      .def(
          "hit_counts",
          [](const TsdfVolume& self, py::handle points_W) {
            const std::vector<openvdb::Coord> voxels = voxelsOf(self, points_W);
            py::array_t<std::int64_t> hits(py::ssize_t(voxels.size()));
            std::int64_t* h = hits.mutable_data();
            withLock(&self, Access::Read, [&] {
              const auto acc = self.hitCountGrid()->getConstAccessor();  // the counts only, not the sums
              for (std::size_t i = 0; i < voxels.size(); ++i) h[i] = acc.getValue(voxels[i]);
              return 0;
            });
            return hits;
          },
          py::arg("points_W"),
          "Surface end points of the integrated frames that fell in the voxels nearest to points (N, 3): "
          "int64 (N,). Thin structure that the tsdf reads free still holds hits.")
      .def(
          "world_to_voxel",
          [](const TsdfVolume& self, py::handle points_W) { return coordsToArray(voxelsOf(self, points_W)); },
          py::arg("points_W"), "Indices (N, 3) int32 of the voxels whose centres are nearest to the points.")
      .def(
          "voxel_center",
          [](const TsdfVolume& self, py::handle ijk) {
            const std::vector<openvdb::Coord> c = toCoords(ijk, "ijk");
            py::array_t<double> out({py::ssize_t(c.size()), py::ssize_t(3)});
            auto o = out.mutable_unchecked<2>();
            for (std::size_t i = 0; i < c.size(); ++i) {
              const Vec3d p = self.voxelCenter(c[i]);
              for (int k = 0; k < 3; ++k) o(py::ssize_t(i), k) = p[k];
            }
            return out;
          },
          py::arg("ijk"), "Centres (N, 3) float64 in metres of voxels (N, 3) integers.")
      .def_property_readonly("active_voxel_count", locked<Access::Read>(&TsdfVolume::activeVoxelCount),
                             "voxels with any weight (known or not)")
      .def_property_readonly("memory_bytes", locked<Access::Read>(&TsdfVolume::memoryBytes),
                             "memory of the exact state in bytes")
      .def(
          "active_bounding_box",
          [](const TsdfVolume& self) {
            return toTuple(withLock(&self, Access::Read, [&] { return self.activeBoundingBox(); }));
          },
          "Index box ((i, j, k) min, (i, j, k) max) inclusive of the voxels with any weight, or None when empty.")
      .def("known_voxels", &knownVoxels,
           "Every known voxel: (ijk int32 (M, 3), tsdf_m float32 (M,), weight float32 (M,)), the active voxels "
           "of the saved 'tsdf' and 'weight' grids, in OpenVDB's tree order.")
      .def(
          "exactly_equals",
          [](const TsdfVolume& self, const TsdfVolume& other) {
            return withLock(&self, Access::Read, [&] {
              const ObjectLock other_lock(&other, Access::Read);  // no GIL here; same object: not locked twice
              return self.exactlyEquals(other);
            });
          },
          py::arg("other"),
           "True when both maps hold bit-identical exact state.");

  v.def("save", locked<Access::Read>(&TsdfVolume::save), py::arg("path"),
        "Writes path (.vdb: float grids 'tsdf' and 'weight' with metadata, readable by vdb_print and pyopenvdb) "
        "and the exact state beside it (exact_state_path(path)). Written to temporaries and renamed. OSError when "
        "it cannot be written.")
      .def_static("load", &TsdfVolume::load, py::arg("path"), py::call_guard<py::gil_scoped_release>(),
                  "A map saved by save(): exact with its companion file, else approximate from the float grids "
                  "(has_exact_state False). OSError naming the file on missing or bad input.")
      .def_static("exact_state_path", &TsdfVolume::exactStatePath, py::arg("path"), "map.vdb -> map.exact.vdb")
      .def_property_readonly("has_exact_state", locked<Access::Read>(&TsdfVolume::hasExactState),
                             "whether the state came from exact data (False after loading without the companion)")
      .def("__copy__", [](const TsdfVolume& self) { return withLock(&self, Access::Read, [&] { return TsdfVolume(self); }); })
      .def(
          "__deepcopy__",
          [](const TsdfVolume& self, py::dict) { return withLock(&self, Access::Read, [&] { return TsdfVolume(self); }); },
          py::arg("memo"))
      .def("__repr__", [](const TsdfVolume& self) {
        const auto [frames, active] = withLock(&self, Access::Read, [&] {
          return std::make_pair(self.frameCount(), self.activeVoxelCount());
        });
        return "TsdfVolume(voxel_size_m=" + std::string(py::repr(py::float_(self.config().voxel_size_m))) +
               ", frame_count=" + std::to_string(frames) + ", active_voxel_count=" + std::to_string(active) + ")";
      });
}

void bindMesh(py::module_& m) {
  m.def(
      "extract_mesh",
      [](const TsdfVolume& volume) {
        TriangleMesh mesh;
        mesh = withLock(&volume, Access::Read, [&] { return extractMesh(volume); });
        return toArrays(mesh);
      },
      py::arg("volume"),
      "The zero level set of the map's known voxels (OpenVDB's volumeToMesh inside a surface mask, so no "
      "spurious back faces): (vertices float32 (V, 3) metres, triangles int32 (T, 3)).");
}

void bindVolume(py::module_& m) {
  bindIntegrationStats(m);
  bindTsdfVolume(m);
  bindMesh(m);
}

const BindRegistration registration(kBindVolume, "volume", &bindVolume);

}  // namespace
}  // namespace vdbmap::python
