// Surface extraction from the TSDF map.
#pragma once

#include "vdbmap/openvdb.hpp"
#include "vdbmap/triangle_mesh.hpp"

namespace vdbmap {

class TsdfVolume;

/// The zero level set of the map's known voxels, by openvdb::tools::volumeToMesh.
///
/// A raw TSDF cannot be meshed directly: behind every observed surface the last negative voxel
/// meets the unobserved +truncation background and makes a spurious back face. So polygons are
/// only generated inside a surface mask: the known voxels eroded by one voxel.
TriangleMesh extractMesh(const TsdfVolume& volume);

/// The same on a tsdf grid as saved in a .vdb (known voxels active, background +truncation).
TriangleMesh extractMesh(const openvdb::FloatGrid& tsdf);

}  // namespace vdbmap
