// Keyframe storage: exact decoding and memory per frame.
#include "vdbmap/keyframe_store.hpp"
#include "vdbmap/testing/analytic_scene.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <limits>

using namespace vdbmap;

TEST_CASE("a stored depth frame decodes to the same points every time, within half a depth unit of the input",
          "[keyframes][store]") {
  auto K = std::make_shared<CameraIntrinsics>();  // 640x480, FUEL's camera
  const testing::AnalyticScene scene = testing::AnalyticScene::demoRoom();
  const Pose3d T = vdbmap::lookingPose({0.5, 0.2, 1.2}, 0.7, 0.2);
  DepthImage depth = scene.renderDepth(*K, T, 5.0);
  depth.at(10, 10) = std::numeric_limits<float>::quiet_NaN();
  depth.at(11, 10) = 0.0f;
  const EncodedFrame f = EncodedFrame::fromDepth(depth, K, 0.001);
  const PointCloud a = f.decode(), b = f.decode();
  REQUIRE(a.size() == std::size_t(K->width * K->height));
  const PointCloud exact = backProject(depth, *K);
  std::size_t invalid = 0;
  double max_err = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    REQUIRE((a[i].allFinite() == b[i].allFinite()));
    if (!a[i].allFinite()) {
      ++invalid;
      continue;
    }
    REQUIRE((a[i].array() == b[i].array()).all());  // bit-identical decodes
    max_err = std::max(max_err, double(std::abs(a[i].z() - exact[i].z())));
  }
  CHECK(invalid >= 2);
  CHECK(max_err <= 0.0005 + 1e-6);
  // Memory: the budget is 150 KB per 640x480 depth frame.
  INFO("bytes per 640x480 frame: " << f.bytes());
  CHECK(f.bytes() <= 150 * 1024);
}

TEST_CASE("stored point clouds keep invalid points invalid and quantize to the unit", "[keyframes][store]") {
  PointCloud pts = {Vec3f(1.2345f, -0.5f, 3.0f), Vec3f::Constant(std::numeric_limits<float>::quiet_NaN()),
                    Vec3f(0.0f, 0.0f, 0.0f)};
  const PointCloud d = EncodedFrame::fromPoints(pts, 0.001).decode();
  REQUIRE(d.size() == 3);
  CHECK(d[0].x() == Approx(1.235f).margin(1e-6));
  CHECK_FALSE(d[1].allFinite());
  CHECK(d[2].isZero());
}

TEST_CASE("quantize and encodeRaw give exactly the frame a decode of the encoded frame gives", "[keyframes][store]") {
  auto K = std::make_shared<CameraIntrinsics>();
  const testing::AnalyticScene scene = testing::AnalyticScene::demoRoom();
  DepthImage depth = scene.renderDepth(*K, vdbmap::lookingPose({0.5, 0.2, 1.2}, 0.7, 0.2), 5.0);
  // Every kind of pixel the coding treats apart: invalid (NaN, infinite, zero, negative), below one
  // unit (clamped to 1), beyond 65535 units (clamped there), and halfway between two units.
  const float special[] = {std::numeric_limits<float>::quiet_NaN(),
                           std::numeric_limits<float>::infinity(),
                           0.0f,
                           -1.0f,
                           1e-5f,
                           80.0f,
                           1.0005f,
                           2.0015f};
  for (int i = 0; i < 8; ++i) depth.at(20 + i, 30) = special[i];
  for (const double unit_m : {0.001, 0.00025, 0.004}) {
    const SensorFrame frame = SensorFrame::depth(depth, K);
    const DepthImage expected = EncodedFrame::encode(frame, unit_m).decodeDepth();
    const SensorFrame quantized = EncodedFrame::quantize(frame, unit_m);
    SensorFrame decoded;
    const EncodedFrame raw = EncodedFrame::encodeRaw(frame, unit_m, decoded);
    REQUIRE(quantized.isDepth());
    REQUIRE(decoded.isDepth());
    CHECK_FALSE(raw.isCompressed());
    const DepthImage raw_decoded = raw.decodeDepth();
    std::size_t differ = 0;  // bitwise: NaN and -0.0 would pass a float comparison wrongly
    for (std::size_t i = 0; i < expected.depth_m.size(); ++i) {
      const float* e = &expected.depth_m[i];
      differ += std::memcmp(e, &quantized.depthImage().depth_m[i], sizeof(float)) != 0 ? 1 : 0;
      differ += std::memcmp(e, &decoded.depthImage().depth_m[i], sizeof(float)) != 0 ? 1 : 0;
      differ += std::memcmp(e, &raw_decoded.depth_m[i], sizeof(float)) != 0 ? 1 : 0;
    }
    INFO("unit " << unit_m);
    CHECK(differ == 0);
    CHECK(raw.compressed().decodeDepth().depth_m == expected.depth_m);
  }
  const PointCloud pts = {Vec3f(1.2345f, -0.5f, 3.0f), Vec3f::Constant(std::numeric_limits<float>::quiet_NaN()),
                          Vec3f(0.0f, std::numeric_limits<float>::infinity(), 0.0f), Vec3f(-0.0005f, 0.0015f, 3e7f)};
  const PointCloud expected = EncodedFrame::fromPoints(pts, 0.001).decode();
  const PointCloud quantized = EncodedFrame::quantize(SensorFrame::points(pts), 0.001).points_S();
  REQUIRE(quantized.size() == expected.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    INFO("point " << i);
    CHECK(std::memcmp(expected[i].data(), quantized[i].data(), sizeof(Vec3f)) == 0);
  }
}

TEST_CASE("the store refuses duplicate ids and names missing ones", "[keyframes][store]") {
  KeyframeStore store;
  Keyframe kf;
  kf.id = 4;
  store.add(kf);
  CHECK_THROWS_WITH(store.add(kf), Catch::Contains("frame 4"));
  CHECK_THROWS_WITH(store.at(5), Catch::Contains("frame 5"));
  CHECK(store.bytes() > 0);
}
