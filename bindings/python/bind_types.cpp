// Enums, camera intrinsics, poses and depth back-projection.
#include "binding.hpp"

#include "vdbmap/config.hpp"
#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/log_replay.hpp"
#include "vdbmap/mapper.hpp"
#include "vdbmap/tsdf_volume.hpp"

namespace vdbmap::python {
namespace {

/// Enums are also made from the names the CLI and files use (Weighting("inverse_square"));
/// str() gives that name back. Config fields accept the names too (defEnumField).
template <typename E>
void addNames(py::enum_<E>& e, E (*parse)(const std::string&), const char* (*name)(E)) {
  e.def(py::init([parse](const std::string& text) { return parse(text); }), py::arg("name"),
        "From the name the CLI and files use; ValueError lists the accepted names.");
  // Replace (not overload) pybind11's own __str__.
  e.attr("__str__") = py::cpp_function([name](E value) { return std::string(name(value)); }, py::name("__str__"),
                                       py::is_method(e), "The name the CLI and files use.");
}

VoxelState parseVoxelState(const std::string& text) {
  for (VoxelState s : {VoxelState::Unknown, VoxelState::Free, VoxelState::Occupied})
    if (text == toString(s)) return s;
  throw std::invalid_argument("voxel state must be unknown, free or occupied, got '" + text + "'");
}
const char* onBadFrameName(OnBadFrame o) { return o == OnBadFrame::Fail ? "fail" : "skip"; }

void bindEnums(py::module_& m) {
  py::enum_<Weighting> weighting(m, "Weighting", "How much one ray counts in a voxel's weighted average.");
  weighting.value("Constant", Weighting::Constant, "every ray weighs 1")
      .value("InverseSquare", Weighting::InverseSquare,
             "1/z^2 with the paper's linear drop-off behind the surface (Eq. 2)");
  addNames(weighting, &parseWeighting, &toString);

  py::enum_<RayMode> ray_mode(m, "RayMode", "How frames become voxel updates.");
  ray_mode.value("Projective", RayMode::Projective,
                 "depth images voxel by voxel (the default); point clouds as merged rays")
      .value("Merged", RayMode::Merged, "bundle rays per end voxel")
      .value("PerRay", RayMode::PerRay, "one ray per point (slow, the reference)");
  addNames(ray_mode, &parseRayMode, &toString);

  py::enum_<ConsistencyMode> mode(m, "ConsistencyMode", "How the mapper keeps the map consistent under corrections.");
  mode.value("None_", ConsistencyMode::None, "ignore corrections (Voxblox-like baseline); str() is 'none'")
      .value("Submap", ConsistencyMode::Submap, "rigid submaps whose anchors move (C-blox-like baseline)")
      .value("All", ConsistencyMode::All, "re-integrate every frame whose pose changed")
      .value("Keyframes", ConsistencyMode::Keyframes, "ours: set-cover pruned keyframes, re-integrated");
  addNames(mode, &parseConsistencyMode, &toString);

  py::enum_<VoxelState> state(m, "VoxelState",
                              "Unknown (weight <= min_weight), Free, or Occupied (tsdf below the occupancy "
                              "threshold). Query arrays hold these as uint8 values 0, 1, 2.");
  state.value("Unknown", VoxelState::Unknown).value("Free", VoxelState::Free).value("Occupied", VoxelState::Occupied);
  addNames(state, &parseVoxelState, &toString);

  py::enum_<OnBadFrame> on_bad(m, "OnBadFrame", "What log replay does with a frame that cannot be used.");
  on_bad.value("Fail", OnBadFrame::Fail, "raise BadFrameError").value("Skip", OnBadFrame::Skip, "list it and go on");
  addNames(on_bad, &parseOnBadFrame, &onBadFrameName);

  py::enum_<io::DatasetFormat> format(m, "DatasetFormat", "The dataset layouts open_dataset reads in place.");
  format.value("Auto", io::DatasetFormat::Auto, "detect the layout")
      .value("Log", io::DatasetFormat::Log, "our log format (sensor.json + frames.csv)")
      .value("SevenScenes", io::DatasetFormat::SevenScenes, "7-Scenes; str() is '7scenes'")
      .value("ThreeDMatch", io::DatasetFormat::ThreeDMatch, "3DMatch; str() is '3dmatch'")
      .value("IclNuim", io::DatasetFormat::IclNuim, "ICL-NUIM")
      .value("Redwood", io::DatasetFormat::Redwood, "Redwood")
      .value("Tum", io::DatasetFormat::Tum, "TUM RGB-D")
      .value("Replica", io::DatasetFormat::Replica, "Replica as in nvblox's tests");
  addNames(format, &io::parseDatasetFormat, &io::toString);

  py::enum_<io::SensorKind> kind(m, "SensorKind", "What a log's frames are.");
  kind.value("Depth", io::SensorKind::Depth, "16-bit depth PNGs")
      .value("Points", io::SensorKind::Points, "point clouds");
  kind.attr("__str__") = py::cpp_function([](io::SensorKind k) { return std::string(io::toString(k)); },
                                          py::name("__str__"), py::is_method(kind), "'depth' or 'points'");
}

void bindIntrinsics(py::module_& m) {
  py::class_<CameraIntrinsics> K(m, "CameraIntrinsics",
                                 "A pinhole depth camera, OpenCV axes (x right, y down, z forward). Pixel (u, v) "
                                 "with depth z is ((u - cx) z / fx, (v - cy) z / fy, z).");
  addStructProtocol(K);
  K.def_readwrite("width", &CameraIntrinsics::width, "image width in pixels (> 0)")
      .def_readwrite("height", &CameraIntrinsics::height, "image height in pixels (> 0)")
      .def_readwrite("fx", &CameraIntrinsics::fx, "focal length in pixels, in (0, 1e7]")
      .def_readwrite("fy", &CameraIntrinsics::fy, "focal length in pixels; may be negative (flipped y)")
      .def_readwrite("cx", &CameraIntrinsics::cx, "principal point x in pixels")
      .def_readwrite("cy", &CameraIntrinsics::cy, "principal point y in pixels")
      .def("validate", &CameraIntrinsics::validate, "Raises ValueError naming the field when a value is out of range.");
}

void bindPoses(py::module_& m) {
  m.def(
      "pose_from_translation_quaternion",
      [](py::handle t, double qx, double qy, double qz, double qw) {
        return toArray(poseFromTranslationQuaternion(toVec3(t, "t"), qx, qy, qz, qw));
      },
      py::arg("t"), py::arg("qx"), py::arg("qy"), py::arg("qz"), py::arg("qw"),
      "A (4, 4) float64 pose from a translation (3,) and a unit quaternion (x, y, z, w), TUM order.");
  m.def(
      "is_valid_rigid_transform",
      [](py::handle T, double tolerance) { return isValidRigidTransform(toPose(T, "T"), tolerance); }, py::arg("T"),
      py::arg("tolerance") = 1e-4,
      "True when every entry is finite and the rotation block is orthonormal with determinant +1 within "
      "`tolerance`.");
}

void bindBackProjection(py::module_& m) {
  m.def(
      "back_project",
      [](py::handle depth, const CameraIntrinsics& K, int stride, std::optional<double> depth_scale) {
        const DepthImage d = toDepth(depth, depth_scale, "depth");
        PointCloud points;
        {
          py::gil_scoped_release nogil;
          points = backProject(d, K, stride);
        }
        return toArray(points);
      },
      py::arg("depth"), py::arg("intrinsics"), py::arg("stride") = 1, py::arg("depth_scale") = py::none(),
      "Points (N, 3) float32 in the sensor frame from a depth image, row by row, every `stride`-th pixel "
      "in both directions. Invalid pixels (0, NaN) become NaN points, which integration skips and counts. "
      "depth: (H, W) float32/float64 metres, or uint16 raw units with depth_scale (metres per unit).");
}

void bindTypes(py::module_& m) {
  bindEnums(m);
  bindIntrinsics(m);
  bindPoses(m);
  bindBackProjection(m);
}

const BindRegistration registration(kBindTypes, "types", &bindTypes);

}  // namespace
}  // namespace vdbmap::python
