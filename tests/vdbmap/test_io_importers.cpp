// Importers of the shared datasets, read in place: frame count, intrinsics, depth scale, first
// pose, one depth value, and a joint check of pose convention + intrinsics + depth scale by
// reprojecting one frame's depth into another (PROVENANCE.md of each dataset gives the figure).
// Also the TUM RGB-D layout on a small synthetic folder, and detection.
#include "test_io_helpers.hpp"

#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/png_io.hpp"

#include <Eigen/Geometry>

#include <cmath>

using namespace vdbmap;
using namespace vdbmap::io;
using vdbmap::test::sharedData;
using vdbmap::test::TempDir;
using vdbmap::test::writeText;

namespace {

constexpr double kPoseTolerance = 1e-6;
// Rotation matrices in the files are orthonormal only to ~5e-5 (6-8 digits); the importers
// project them onto SO(3), which moves entries by about as much.
constexpr double kRotationTolerance = 1e-4;
constexpr double kDepthTolerance_m = 1e-6;
constexpr double kAgreementDistance_m = 0.03;  // as in the PROVENANCE.md checks
constexpr int kReprojectionStride = 4;

/// Fraction of frame i's valid depth pixels that, moved into frame j with the poses and
/// intrinsics of the source, land in j's image on a valid depth within kAgreementDistance_m.
/// `wrong_convention` = 1 inverts the poses, 2 flips the sign of fy: negative controls showing
/// that the check does fail under the wrong convention.
double reprojectionAgreement(const FrameSource& src, std::size_t i, std::size_t j, int wrong_convention = 0) {
  const Frame a = src.load(i), b = src.load(j);
  CameraIntrinsics K = src.sensor().intrinsics;
  if (wrong_convention == 2) K.fy = -K.fy;
  const PointCloud pts = backProject(a.data.depthImage(), K, kReprojectionStride);
  const Pose3d T_b_a = wrong_convention == 1 ? Pose3d(b.T_W_S * a.T_W_S.inverse()) : Pose3d(b.T_W_S.inverse() * a.T_W_S);
  std::size_t in_view = 0, agree = 0;
  for (const Vec3f& p : pts) {
    if (!p.allFinite()) continue;
    const Vec3d q = T_b_a * p.cast<double>();
    if (q.z() <= 0.0) continue;
    const int u = int(std::lround(K.fx * q.x() / q.z() + K.cx));
    const int v = int(std::lround(K.fy * q.y() / q.z() + K.cy));
    if (u < 0 || v < 0 || u >= K.width || v >= K.height) continue;
    const float d = b.data.depthImage().at(u, v);
    if (!(d > 0.0f)) continue;
    ++in_view;
    if (std::abs(double(d) - q.z()) < kAgreementDistance_m) ++agree;
  }
  const double fraction = in_view == 0 ? 0.0 : double(agree) / double(in_view);
  UNSCOPED_INFO(src.format() << " " << i << " -> " << j << " (wrong convention " << wrong_convention
                             << "): " << fraction << " of " << in_view);
  return fraction;
}

void checkPose(const Pose3d& T, const Eigen::Vector3d& t, const Eigen::Vector3d& first_row) {
  CHECK((T.translation() - t).cwiseAbs().maxCoeff() < kPoseTolerance);
  CHECK((T.linear().row(0).transpose() - first_row).cwiseAbs().maxCoeff() < kRotationTolerance);
  CHECK(isValidRigidTransform(T, 1e-12));
}

}  // namespace

TEST_CASE("7-Scenes importer (tsdf-fusion-python layout)", "[io][importers][shared]") {
  const auto path = sharedData("7scenes_redkitchen_tsdf_fusion_python");
  CHECK(detectDatasetFormat(path) == DatasetFormat::SevenScenes);
  const auto src = openDataset(path);
  CHECK(src->format() == "7scenes");
  REQUIRE(src->size() == 500);  // even frames only
  const CameraIntrinsics& K = src->sensor().intrinsics;
  CHECK((K.width == 640 && K.height == 480));
  CHECK((K.fx == 585.0 && K.fy == 585.0 && K.cx == 320.0 && K.cy == 240.0));
  CHECK(src->sensor().depth_scale == 0.001);
  CHECK(src->record(1).file.filename() == "frame-000002.depth.png");
  CHECK(src->record(1).timestamp_s == Approx(2.0 / 30.0));
  const Frame f = src->load(0);
  checkPose(f.T_W_S, {-0.34045634, 0.016469818, 0.29656917}, {0.9093129, 0.27262229, -0.31422433});
  CHECK(std::abs(f.data.depthImage().at(320, 240) - 1.382) < kDepthTolerance_m);
  CHECK(f.data.depthImage().at(100, 50) == 0.0f);
  // PROVENANCE.md: frames 0 -> 50 agree 91 % within 3 cm (2-5 % with inverted poses).
  CHECK(reprojectionAgreement(*src, 0, 25) > 0.8);
  CHECK(reprojectionAgreement(*src, 0, 25, /*inverted poses*/ 1) < 0.3);
}

TEST_CASE("3DMatch importer (nvblox test data)", "[io][importers][shared]") {
  for (const char* rel : {"nvblox_testdata/3dmatch", "nvblox_testdata/3dmatch/seq-01"}) {
    INFO(rel);
    const auto src = openDataset(sharedData(rel));
    CHECK(src->format() == "3dmatch");
    REQUIRE(src->size() == 5);
    const CameraIntrinsics& K = src->sensor().intrinsics;
    CHECK((K.fx == 570.342205 && K.fy == 570.342205 && K.cx == 320.0 && K.cy == 240.0));
    CHECK(src->record(3).file.filename() == "frame-000116.depth.png");
    const Frame f = src->load(0);
    checkPose(f.T_W_S, {1.973046, 1.125734, 0.309820}, {0.313181, 0.309473, -0.897856});
    CHECK(std::abs(f.data.depthImage().at(320, 240) - 2.485) < kDepthTolerance_m);
  }
  // PROVENANCE.md: frame 0 -> 1 agree 74 % within 3 cm.
  CHECK(reprojectionAgreement(*openDataset(sharedData("nvblox_testdata/3dmatch")), 0, 1) > 0.6);
}

TEST_CASE("ICL-NUIM importer (slambook2 layout, fy < 0)", "[io][importers][shared]") {
  const auto path = sharedData("iclnuim_livingroom_5frames_slambook2");
  CHECK(detectDatasetFormat(path) == DatasetFormat::IclNuim);
  const auto src = openDataset(path);
  REQUIRE(src->size() == 5);
  const CameraIntrinsics& K = src->sensor().intrinsics;
  CHECK((K.fx == 481.2 && K.fy == -480.0 && K.cx == 319.5 && K.cy == 239.5));
  CHECK(src->sensor().depth_scale == Approx(1.0 / 5000.0));
  const Frame f = src->load(0);
  const Pose3d ref = poseFromTranslationQuaternion({0.000466347, 0.00895357, -2.24935}, -0.00101358, 0.00052453, -0.000231475, 0.999999);
  CHECK((f.T_W_S.matrix() - ref.matrix()).cwiseAbs().maxCoeff() < kPoseTolerance);
  CHECK(std::abs(f.data.depthImage().at(320, 240) - 16890.0 / 5000.0) < kDepthTolerance_m);
  // PROVENANCE.md: 1 -> 3 agree 82-92 % (<= 34 % with fy = +480 or inverted poses).
  CHECK(reprojectionAgreement(*src, 0, 2) > 0.7);
  CHECK(reprojectionAgreement(*src, 0, 2, /*fy = +480*/ 2) < 0.4);
}

TEST_CASE("Redwood importer (Open3D test data)", "[io][importers][shared]") {
  for (const char* rel : {"open3d_testdata_redwood_tum", "open3d_testdata_redwood_tum/RGBD"}) {
    INFO(rel);
    CHECK(detectDatasetFormat(sharedData(rel)) == DatasetFormat::Redwood);
    const auto src = openDataset(sharedData(rel));
    CHECK(src->format() == "redwood");
    REQUIRE(src->size() == 5);
    const CameraIntrinsics& K = src->sensor().intrinsics;  // from camera_primesense.json (column-major)
    CHECK((K.width == 640 && K.fx == 525.0 && K.fy == 525.0 && K.cx == 319.5 && K.cy == 239.5));
    const Frame f = src->load(0);
    checkPose(f.T_W_S, {-0.31057997014702826, 0.5730122438481298, 2.1264800183565487},
              {-0.2739592186924325, 0.021819345900466677, -0.9614937663021573});
    CHECK(std::abs(f.data.depthImage().at(320, 240) - 2.195) < kDepthTolerance_m);
    // PROVENANCE.md: consecutive frames agree 97.7-98.4 %.
    CHECK(reprojectionAgreement(*src, 0, 1) > 0.9);
  }
}

TEST_CASE("Replica importer (nvblox test data)", "[io][importers][shared]") {
  for (const char* rel : {"nvblox_testdata/replica", "nvblox_testdata/replica/office0"}) {
    INFO(rel);
    CHECK(detectDatasetFormat(sharedData(rel)) == DatasetFormat::Replica);
    const auto src = openDataset(sharedData(rel));
    REQUIRE(src->size() == 4);
    const CameraIntrinsics& K = src->sensor().intrinsics;
    CHECK((K.width == 1200 && K.height == 680 && K.fx == 600.0 && K.fy == 600.0 && K.cx == 599.5 && K.cy == 339.5));
    CHECK(src->sensor().depth_scale == Approx(1.0 / 6553.5));
    const Frame f = src->load(0);
    checkPose(f.T_W_S, {-0.3569159214564542, -0.6602722315763628, 0.8192365926179191},
              {0.9062491181555123, -0.2954311239679593, 0.3023788796086531});
    CHECK(std::abs(f.data.depthImage().at(320, 240) - 15126.0 / 6553.5) < kDepthTolerance_m);
    CHECK(reprojectionAgreement(*src, 0, 1) > 0.8);
  }
}

TEST_CASE("TUM RGB-D importer on a small synthetic sequence", "[io][importers]") {
  TempDir dir;
  const auto root = dir / "tum";
  std::filesystem::create_directories(root / "depth");
  // Ground truth at 100 Hz moving along x at 1 m/s, yaw rate 0.5 rad/s; depth at 30 Hz.
  std::string gt = "# ground truth trajectory\n# timestamp tx ty tz qx qy qz qw\n";
  for (int k = 0; k <= 20; ++k) {
    const double t = 100.0 + 0.01 * k;
    const Eigen::Quaterniond q(Eigen::AngleAxisd(0.5 * (t - 100.0), Eigen::Vector3d::UnitZ()));
    char line[256];
    std::snprintf(line, sizeof(line), "%.4f %.6f 0 1.5 %.9f %.9f %.9f %.9f\n", t, t - 100.0, q.x(), q.y(), q.z(), q.w());
    gt += line;
  }
  writeText(root / "groundtruth.txt", gt);
  std::string list = "# depth maps\n";
  for (int i = 0; i < 4; ++i) {
    const double t = 100.005 + i / 30.0;
    char name[64];
    std::snprintf(name, sizeof(name), "depth/%.6f.png", t);
    writeDepthPng(root / name, DepthImage(640, 480, 2.0f + 0.5f * float(i)), 1.0 / 5000.0);
    list += formatTimestamp(t) + " " + name + "\n";
  }
  list += "100.300000 depth/late.png\n";  // beyond the ground truth
  writeText(root / "depth.txt", list);
  CHECK(detectDatasetFormat(root) == DatasetFormat::Tum);
  const auto src = openDataset(root);
  CHECK(src->format() == "tum");
  REQUIRE(src->size() == 5);
  CHECK(src->sensor().intrinsics.fx == 525.0);
  const Frame f = src->load(1);
  const double t = 100.005 + 1 / 30.0;
  CHECK(f.timestamp_s == Approx(t).margin(1e-6));
  CHECK(f.T_W_S.translation().x() == Approx(t - 100.0).margin(1e-6));  // interpolated
  CHECK(Eigen::AngleAxisd(f.T_W_S.linear()).angle() == Approx(0.5 * (t - 100.0)).margin(1e-6));
  CHECK(f.data.depthImage().at(5, 5) == Approx(2.5f));
  CHECK(src->groundTruth().size() == 21);
  VDBMAP_REQUIRE_THROWS_MENTIONING(src->load(4), "frame 4", "depth.txt:6", "ground-truth");
  // A sensor.json beside depth.txt overrides the default intrinsics.
  writeText(root / "sensor.json", R"({"kind": "depth", "width": 640, "height": 480, "fx": 517.3, "fy": 516.5,
      "cx": 318.6, "cy": 255.3, "depth_scale": 0.0002})");
  CHECK(openDataset(root)->sensor().intrinsics.fx == 517.3);
}

TEST_CASE("Importers report per-frame problems as BadFrameError and layout problems at open", "[io][importers][bad-input]") {
  TempDir dir;
  const auto seq = dir / "seq";
  std::filesystem::create_directories(seq);
  const std::string ident = "1 0 0 0\n0 1 0 0\n0 0 1 1.5\n0 0 0 1\n";
  for (int i = 0; i < 3; ++i) {
    char name[64];
    std::snprintf(name, sizeof(name), "frame-%06d.depth.png", i);
    writeDepthPng(seq / name, DepthImage(64, 48, 1.0f), 0.001);
  }
  writeText(seq / "frame-000000.pose.txt", ident);
  writeText(seq / "frame-000001.pose.txt", "1 0 0 0\n0 2 0 0\n0 0 1 1.5\n0 0 0 1\n");  // not a rotation
  // frame 2 has no pose file
  const auto src = openDataset(seq);
  CHECK(src->format() == "7scenes");
  REQUIRE(src->size() == 3);
  CHECK(src->sensor().intrinsics.width == 64);  // image size from the first PNG header
  CHECK(src->sensor().intrinsics.fx == 585.0);   // 7-Scenes' documented default: no camera-intrinsics.txt
  CHECK_NOTHROW(src->load(0));
  VDBMAP_REQUIRE_THROWS_MENTIONING(src->load(1), "frame 1", "frame-000001.pose.txt", "orthonormal");
  CHECK_THROWS_AS(src->load(2), BadFrameError);
  VDBMAP_REQUIRE_THROWS_MENTIONING(src->load(2), "frame 2", "no pose file");
  // Redwood: a truncated .log names the file and the line where the broken pose starts.
  const auto rw = dir / "rw";
  std::filesystem::create_directories(rw / "depth");
  writeDepthPng(rw / "depth" / "00000.png", DepthImage(640, 480, 1.0f), 0.001);
  writeText(rw / "trajectory.log", "0 0 1\n" + ident + "1 1 2\n1 0 0 0\n");
  VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(rw), "trajectory.log", "line 6");
  // Two sequences under one scene are ambiguous.
  std::filesystem::create_directories(dir / "scene");
  std::filesystem::copy(seq, dir / "scene" / "seq-01", std::filesystem::copy_options::recursive);
  std::filesystem::copy(seq, dir / "scene" / "seq-02", std::filesystem::copy_options::recursive);
  VDBMAP_REQUIRE_THROWS_MENTIONING(openDataset(dir / "scene"), "scene", "seq-01", "seq-02");
  CHECK(openDataset(dir / "scene" / "seq-02")->size() == 3);
  CHECK_THROWS_AS(parseDatasetFormat("kitti"), std::invalid_argument);
  CHECK(parseDatasetFormat("replica") == DatasetFormat::Replica);
}
