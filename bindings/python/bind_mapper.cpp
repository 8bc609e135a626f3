// Mapper: the four consistency modes, frames, pose updates, budgeted re-integration, keyframes.
#include "binding.hpp"
#include "object_lock.hpp"

#include "vdbmap/mapper.hpp"

#include <memory>

namespace vdbmap::python {
namespace {

void bindReports(py::module_& m) {
  py::class_<CycleReport> c(m, "CycleReport",
                            "What one background cycle did (re-integrations and de-integrations of dropped frames).");
  c.def_readonly("frames", &CycleReport::frames, "frames re-integrated in this cycle")
      .def_readonly("frames_deintegrated", &CycleReport::frames_deintegrated,
                    "frames set cover dropped, de-integrated and released in this cycle")
      .def_readonly("ms", &CycleReport::ms, "time spent in milliseconds")
      .def_readonly("queued_left", &CycleReport::queued_left, "frames still waiting (both kinds)")
      .def("__repr__", [](py::handle self) { return reprOfProperties(self); });

  py::class_<MapperStats> s(m, "MapperStats", "Counters of a Mapper's life.");
  s.def_readonly("frames_total", &MapperStats::frames_total, "frames given to the mapper")
      .def_readonly("frames_dropped", &MapperStats::frames_dropped,
                    "dropped by pruning, then de-integrated and released")
      .def_readonly("reintegrated_frames", &MapperStats::reintegrated_frames,
                    "re-integrations done (a frame may count many times)")
      .def_readonly("background_frames", &MapperStats::background_frames,
                    "frames the background cycles processed (re-integrations and drops)")
      .def_readonly("reintegration_cycles", &MapperStats::reintegration_cycles,
                    "background cycles that processed at least one frame")
      .def_readonly("reintegration_ms_total", &MapperStats::reintegration_ms_total, "time in background cycles")
      .def_readonly("reintegration_ms_max_cycle", &MapperStats::reintegration_ms_max_cycle, "the longest cycle")
      .def_readonly("pruning_solves", &MapperStats::pruning_solves, "set-cover solves (keyframes mode)")
      .def_readonly("submaps", &MapperStats::submaps, "rigid submaps started (submap mode)")
      .def("__repr__", [](py::handle self) { return reprOfProperties(self); });

  py::class_<Keyframe> k(m, "Keyframe", "A stored keyframe (a copy): its poses and its data.");
  k.def_readonly("id", &Keyframe::id, "its frame id")
      .def_readonly("timestamp", &Keyframe::timestamp, "seconds")
      .def_property_readonly(
          "T_W_S_integrated", [](const Keyframe& f) { return toArray(f.T_W_S_integrated); },
          "(4, 4) the pose the map currently holds it at")
      .def_property_readonly(
          "T_W_S_latest", [](const Keyframe& f) { return toArray(f.T_W_S_latest); },
          "(4, 4) the newest estimate (odometry or correction)")
      .def_readonly("integrated", &Keyframe::integrated, "whether the map currently holds it")
      .def_property_readonly(
          "bytes", [](const Keyframe& f) { return f.data.bytes(); }, "bytes of its compressed data")
      .def(
          "points_S", [](const Keyframe& f) { return toArray(f.data.decode()); },
          "Its points (N, 3) float32 in the sensor frame, as stored (quantized).")
      .def(
          "depth",
          [](const Keyframe& f) -> py::object {
            if (!f.data.isDepth()) return py::none();
            return toArray(f.data.decodeDepth());
          },
          "Its depth image (H, W) float32 metres as stored and integrated (None for point frames).")
      .def("__repr__", [](const Keyframe& f) {
        return "Keyframe(id=" + std::to_string(f.id) + ", timestamp=" + std::string(py::repr(py::float_(f.timestamp))) +
               ", integrated=" + (f.integrated ? "True" : "False") + ")";
      });
}

void bindMapperClass(py::module_& m) {
  py::class_<Mapper> c(m, "Mapper",
                       "One engine, four ways to keep the map consistent when loop closure corrects poses "
                       "(MapperConfig.mode): none, submap, all, keyframes (ours, set-cover pruned).");
  c.def(py::init<const MapperConfig&>(), py::arg("config") = MapperConfig{},
        "ValueError naming the field when the config is out of range.")
      .def_property_readonly(
          "config", [](const Mapper& self) { return self.config(); }, "MapperConfig (a copy)");

  c.def(
       "add_depth_frame",
       [](Mapper& self, FrameId id, double timestamp, py::handle depth, const CameraIntrinsics& K, py::handle T_W_S,
          std::optional<double> depth_scale) {
         const SensorFrame frame =
             SensorFrame::depth(toDepth(depth, depth_scale, "depth"), std::make_shared<const CameraIntrinsics>(K));
         const Pose3d T = toPose(T_W_S, "T_W_S");
         return withLock(&self, Access::Write, [&] { return self.addFrame(id, timestamp, frame, T); });
       },
       py::arg("frame_id"), py::arg("timestamp"), py::arg("depth"), py::arg("intrinsics"), py::arg("T_W_S"),
       py::arg("depth_scale") = py::none(),
       "Stores (except in none mode) and integrates a depth frame seen from T_W_S (odometry). depth: (H, W) "
       "float32/float64 metres, or uint16 with depth_scale (metres per unit). ValueError when frame_id was "
       "already given.")
      .def(
          "add_point_frame",
          [](Mapper& self, FrameId id, double timestamp, py::handle points_S, py::handle T_W_S) {
            const SensorFrame frame = SensorFrame::points(toPoints(points_S, "points_S"));
            const Pose3d T = toPose(T_W_S, "T_W_S");
            return withLock(&self, Access::Write, [&] { return self.addFrame(id, timestamp, frame, T); });
          },
          py::arg("frame_id"), py::arg("timestamp"), py::arg("points_S"), py::arg("T_W_S"),
          "Same for points (N, 3) in the sensor frame.")
      .def(
          "update_poses",
          [](Mapper& self, py::handle poses) {
            const std::map<FrameId, Pose3d> p = toPoseMap(poses, "poses");
            return withLock(&self, Access::Write, [&] { return self.updatePoses(p); });
          },
          py::arg("poses"),
          "New pose estimates {frame_id: (4, 4) T_W_S} (a loop-closure correction). Frames moved beyond the "
          "gates are queued for re-integration (all, keyframes) or move their submap (submap); none ignores "
          "them; unknown ids are skipped. Returns how many frames (or anchors) changed.")
      .def(
          "reintegrate",
          [](Mapper& self, py::handle robot_W) {
            const Vec3d r = toVec3(robot_W, "robot_W");
            return withLock(&self, Access::Write, [&] { return self.reintegrate(r); });
          },
          py::arg("robot_W"), "One budgeted background cycle (re-integrations and de-integrations of dropped frames), frames "
          "nearest to robot_W (3,) first.")
      .def(
          "reintegrate_all",
          [](Mapper& self, py::handle robot_W) {
            const Vec3d r = toVec3(robot_W, "robot_W");
            return withLock(&self, Access::Write, [&] { return self.reintegrateAll(r); });
          },
          py::arg("robot_W"),
          "Works off every waiting frame (re-integrations, dropped frames) and the last pruning solve; returns how "
          "many frames.")
      .def_property_readonly("queued_frames", locked<Access::Read>(&Mapper::queuedFrames),
                             "frames awaiting background work (re-integration or de-integration)");

  c.def(
       "volume",
       [](const Mapper& self) { return withLock(&self, Access::Read, [&] { return TsdfVolume(self.volume()); }); },
       "A snapshot of the map (a deep copy, independent of the mapper): in submap mode the fusion of all "
       "submaps. Keep it in a variable rather than calling this per query.")
      .def(
          "take_dirty_region",
          [](Mapper& self) { return toTuple(withLock(&self, Access::Write, [&] { return self.takeDirtyRegion(); })); },
          "Voxel box ((i, j, k) min, (i, j, k) max) changed since the last call, or None.")
      .def_property_readonly(
          "stats", locked<Access::Read>(&Mapper::stats), "MapperStats (a copy)")
      .def_property_readonly("keyframes_kept", locked<Access::Read>(&Mapper::keyframesKept),
                             "frames whose data the mapper keeps")
      .def_property_readonly("keyframe_store_bytes", locked<Access::Read>(&Mapper::keyframeStoreBytes),
                             "bytes of the stored (compressed) keyframes")
      .def(
          "keyframe_ids",
          [](const Mapper& self) {
            return withLock(&self, Access::Read, [&] {
              std::vector<FrameId> ids;
              for (const auto& [id, kf] : self.keyframes()) ids.push_back(id);
              return ids;
            });
          },
          "Ids of the stored keyframes, ascending.")
      .def(
          "keyframe",
          [](const Mapper& self, FrameId id) {
            return withLock(&self, Access::Read, [&] { return Keyframe(self.keyframes().at(id)); });
          },
          py::arg("frame_id"), "A copy of a stored keyframe; IndexError when it is not stored (e.g. pruned).")
      .def(
          "save",
          [](const Mapper& self, const std::filesystem::path& path) {
            withLock(&self, Access::Read, [&] { self.save(path); });
          },
          py::arg("path"),
          "Writes the map (path, .vdb, with its .exact.vdb) and in all and keyframes modes the keyframe store "
          "(.keyframes) beside it: what Mapper.load needs to correct the map later. RuntimeError while background "
          "work is queued (reintegrate_all first), OSError naming a file that cannot be written.")
      .def_static(
          "load",
          [](const std::filesystem::path& path) {
            py::gil_scoped_release nogil;
            return Mapper::load(path);
          },
          py::arg("path"),
          "A mapper in all mode holding a saved map and its keyframes: update_poses then reintegrate_all correct it "
          "as if its frames had been integrated at the new poses. OSError naming the file when the exact state or "
          "the keyframe store is missing, malformed or of another run.")
      .def_static("keyframes_path", &Mapper::keyframesPath, py::arg("map_path"), "MAP.vdb -> MAP.keyframes");
}

void bindMapper(py::module_& m) {
  bindReports(m);
  bindMapperClass(m);
}

const BindRegistration registration(kBindMapper, "mapper", &bindMapper);

}  // namespace
}  // namespace vdbmap::python
