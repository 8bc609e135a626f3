#include "vdbmap/mesh.hpp"

#include "vdbmap/tsdf_volume.hpp"

#include <openvdb/tools/Morphology.h>
#include <openvdb/tools/VolumeToMesh.h>

namespace vdbmap {

TriangleMesh extractMesh(const openvdb::FloatGrid& tsdf) {
  TriangleMesh mesh;
  if (tsdf.tree().activeVoxelCount() == 0) return mesh;

  auto mask = openvdb::BoolGrid::create(false);
  mask->setTransform(tsdf.transform().copy());
  mask->tree().topologyUnion(tsdf.tree());
  openvdb::tools::erodeActiveValues(mask->tree(), 1, openvdb::tools::NN_FACE, openvdb::tools::IGNORE_TILES);

  openvdb::tools::VolumeToMesh mesher(0.0, 0.0);
  mesher.setSurfaceMask(mask, false);
  mesher(tsdf);

  const openvdb::tools::PointList& points = mesher.pointList();
  mesh.vertices.reserve(mesher.pointListSize());
  for (std::size_t i = 0; i < mesher.pointListSize(); ++i)
    mesh.vertices.emplace_back(points[i].x(), points[i].y(), points[i].z());

  // OpenVDB's polygons wind clockwise seen from outside (positive side); flip to counter-clockwise.
  openvdb::tools::PolygonPoolList& pools = mesher.polygonPoolList();
  for (std::size_t p = 0; p < mesher.polygonPoolListSize(); ++p) {
    const openvdb::tools::PolygonPool& pool = pools[p];
    for (std::size_t q = 0; q < pool.numQuads(); ++q) {
      const openvdb::Vec4I& v = pool.quad(q);
      mesh.triangles.emplace_back(int(v[0]), int(v[2]), int(v[1]));
      mesh.triangles.emplace_back(int(v[0]), int(v[3]), int(v[2]));
    }
    for (std::size_t t = 0; t < pool.numTriangles(); ++t) {
      const openvdb::Vec3I& v = pool.triangle(t);
      mesh.triangles.emplace_back(int(v[0]), int(v[2]), int(v[1]));
    }
  }
  return mesh;
}

TriangleMesh extractMesh(const TsdfVolume& volume) { return extractMesh(*volume.tsdfGrid()); }

}  // namespace vdbmap
