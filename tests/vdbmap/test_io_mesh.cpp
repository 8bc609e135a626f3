// Triangle-mesh reading: PLY (ascii, binary little/big endian), OBJ, OFF on small fixtures and on
// the shared worlds, round trip through writePlyMesh, and malformed input naming file and line.
#include "test_io_helpers.hpp"

#include "vdbmap/io/mesh_io.hpp"

#include <Eigen/Geometry>

#include <set>

using vdbmap::TriangleMesh;
using vdbmap::io::readTriangleMesh;
using vdbmap::test::fixture;
using vdbmap::test::TempDir;
using vdbmap::test::writeText;

namespace {

// Outward-facing cube with 12 triangles: the signed volume (divergence theorem) is +1 exactly.
double signedVolume(const TriangleMesh& m) {
  double v = 0.0;
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d a = m.vertices[t[0]].cast<double>(), b = m.vertices[t[1]].cast<double>(),
                          c = m.vertices[t[2]].cast<double>();
    v += a.dot(b.cross(c)) / 6.0;
  }
  return v;
}

void requireUnitCube(const TriangleMesh& m) {
  REQUIRE(m.vertices.size() == 8);
  REQUIRE(m.triangles.size() == 12);
  CHECK(m.vertices[6].isApprox(vdbmap::Vec3f(1, 1, 1)));
  CHECK(m.vertices[4].isApprox(vdbmap::Vec3f(0, 0, 1)));
  // First quad (0,3,2,1) fanned into (0,3,2) and (0,2,1).
  CHECK(m.triangles[0] == Eigen::Vector3i(0, 3, 2));
  CHECK(m.triangles[1] == Eigen::Vector3i(0, 2, 1));
  constexpr double kVolumeTolerance = 1e-9;
  CHECK(std::abs(signedVolume(m) - 1.0) < kVolumeTolerance);
}

}  // namespace

TEST_CASE("readTriangleMesh reads the cube fixture in every format", "[io][mesh]") {
  for (const char* name : {"cube_ascii.ply", "cube_binary_le.ply", "cube_binary_be.ply", "cube.obj", "cube.off"}) {
    INFO(name);
    requireUnitCube(readTriangleMesh(fixture(name)));
  }
}

TEST_CASE("writePlyMesh then readTriangleMesh is exact", "[io][mesh]") {
  TriangleMesh m = readTriangleMesh(fixture("cube.off"));
  m.vertices[3] = vdbmap::Vec3f(0.1f, -2.5f, 1e-7f);
  TempDir dir;
  vdbmap::io::writePlyMesh(dir / "out.ply", m);
  const TriangleMesh back = readTriangleMesh(dir / "out.ply");
  REQUIRE(back.vertices == m.vertices);
  REQUIRE(back.triangles == m.triangles);
}

TEST_CASE("readTriangleMesh reads the shared worlds and ground-truth meshes", "[io][mesh][shared]") {
  using vdbmap::test::sharedData;
  SECTION("Replica office0 ground truth (binary PLY with RGBA)") {
    const TriangleMesh m = readTriangleMesh(sharedData("nvblox_testdata/replica/office0_mesh.ply"));
    CHECK(m.vertices.size() == 25149);
    CHECK(m.triangles.size() == 50000);
    Eigen::AlignedBox3f box;
    for (const auto& v : m.vertices) box.extend(v);
    // PROVENANCE.md: bounding box [-2.01, -3.15, -1.17] to [2.39, 1.85, 1.82] m.
    constexpr float kBoxTolerance_m = 0.01f;
    CHECK(box.min().isApprox(Eigen::Vector3f(-2.01f, -3.15f, -1.17f), kBoxTolerance_m));
    CHECK((box.max() - Eigen::Vector3f(2.39f, 1.85f, 1.82f)).cwiseAbs().maxCoeff() < kBoxTolerance_m);
  }
  SECTION("AWS small house visual mesh") {
    const TriangleMesh m = readTriangleMesh(sharedData("aws_small_house_world/small_house_visual_mesh.ply"));
    CHECK(m.vertices.size() == 78665);
    CHECK(m.triangles.size() == 145696);
  }
  SECTION("Stanford bunny and armadillo (ascii OFF)") {
    const TriangleMesh bunny = readTriangleMesh(sharedData("stanford_bunny_armadillo_cgal_debian/bunny00.off"));
    CHECK(bunny.vertices.size() == 37706);
    CHECK(bunny.triangles.size() == 75408);
    const TriangleMesh arma = readTriangleMesh(sharedData("stanford_bunny_armadillo_cgal_debian/armadillo.off"));
    CHECK(arma.vertices.size() == 26002);
    CHECK(arma.triangles.size() == 52000);
  }
}

TEST_CASE("readTriangleMesh rejects malformed meshes naming file and line", "[io][mesh][bad-input]") {
  TempDir dir;
  SECTION("missing file") {
    VDBMAP_REQUIRE_THROWS_MENTIONING(readTriangleMesh(dir / "nope.ply"), "nope.ply", "no such file");
  }
  SECTION("unknown extension") {
    writeText(dir / "m.stl", "solid x\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readTriangleMesh(dir / "m.stl"), "m.stl", ".stl");
  }
  SECTION("PLY ascii with a bad number") {
    writeText(dir / "bad.ply",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
              "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 zero\n0 1 0\n3 0 1 2\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readTriangleMesh(dir / "bad.ply"), "bad.ply:11:", "'zero'");
  }
  SECTION("PLY ascii face index out of range") {
    writeText(dir / "bad.ply",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
              "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readTriangleMesh(dir / "bad.ply"), "bad.ply:13:", "vertex 3");
  }
  SECTION("PLY binary truncated") {
    const std::string full = vdbmap::test::readBytes(fixture("cube_binary_le.ply"));
    writeText(dir / "cut.ply", full.substr(0, full.size() - 10));
    VDBMAP_REQUIRE_THROWS_MENTIONING(readTriangleMesh(dir / "cut.ply"), "cut.ply", "truncated", "'face'");
  }
  SECTION("PLY without end_header") {
    writeText(dir / "head.ply", "ply\nformat ascii 1.0\nelement vertex 3\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readTriangleMesh(dir / "head.ply"), "head.ply", "end_header");
  }
  SECTION("OBJ face referring to a missing vertex") {
    writeText(dir / "bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 3\nf 1 2 4\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readTriangleMesh(dir / "bad.obj"), "bad.obj:6:", "vertex 4");
  }
  SECTION("OBJ vertex with two coordinates") {
    writeText(dir / "bad.obj", "# c\nv 0 0\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readTriangleMesh(dir / "bad.obj"), "bad.obj:2:");
  }
  SECTION("OFF truncated in the face list") {
    writeText(dir / "cut.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readTriangleMesh(dir / "cut.off"), "cut.off", "truncated", "2 faces");
  }
  SECTION("OFF face with too few indices") {
    writeText(dir / "bad.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n");
    VDBMAP_REQUIRE_THROWS_MENTIONING(readTriangleMesh(dir / "bad.off"), "bad.off:6:");
  }
}
