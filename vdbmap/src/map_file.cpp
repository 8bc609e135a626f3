#include "vdbmap/map_file.hpp"

#include "internal/vdb_file_check.hpp"

#include "vdbmap/file_error.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <stdexcept>

namespace vdbmap {

namespace detail {
/// Throws FileError naming the file and both versions when `meta` holds a vdbmap_format_version
/// newer than this build writes (defined in tsdf_volume_io.cpp beside the version constant).
void checkMapFormatVersion(const openvdb::MetaMap& meta, const std::filesystem::path& path);
/// Throws FileError unless `exact_meta` is a readable companion of the same save as `map_meta`;
/// returns the companion's weight scale.
std::int64_t checkExactCompanion(const openvdb::MetaMap& map_meta, const openvdb::MetaMap& exact_meta,
                                 const std::filesystem::path& map_path, const std::filesystem::path& exact_path);
}  // namespace detail

namespace {
// Opens a map and refuses one of a newer format than this build reads. Every vdbmap reader opens
// files without delayed loading: the maps are read whole anyway, and OpenVDB's delayed-load path
// trusts the file's per-leaf metadata (a damaged entry made it abort in DelayedLoadMetadata::getMask;
// fuzz/regressions/fuzz_vdb).
openvdb::io::File openFile(const std::filesystem::path& path) {
  initializeOpenVdb();
  if (!std::filesystem::is_regular_file(path)) throw vdbmap::FileError("cannot open map " + path.string() + ": no such file");
  internal::checkVdbFileStructure(path);
  openvdb::io::File file(path.string());
  try {
    file.open(/*delayLoad=*/false);
  } catch (const openvdb::Exception& e) {
    throw vdbmap::FileError("cannot read map " + path.string() + ": " + e.what());
  }
  detail::checkMapFormatVersion(*file.getMetadata(), path);
  return file;
}
}  // namespace

openvdb::FloatGrid::Ptr readTsdfGrid(const std::filesystem::path& path) {
  openvdb::io::File file = openFile(path);
  if (!file.hasGrid("tsdf")) throw vdbmap::FileError(path.string() + ": no grid named 'tsdf' (not a vdbmap map?)");
  openvdb::FloatGrid::Ptr grid;
  try {
    grid = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("tsdf"));
  } catch (const openvdb::Exception& e) {  // e.g. "KeyError: Map is not registered" for a damaged transform
    throw vdbmap::FileError("cannot read map " + path.string() + ": grid 'tsdf': " + e.what());
  }
  if (!grid) throw vdbmap::FileError(path.string() + ": grid 'tsdf' is not a float grid");
  return grid;
}

namespace {
MapFileInfo inspectOpenedMapFile(const std::filesystem::path& path) {
  openvdb::io::File file = openFile(path);
  MapFileInfo info;
  info.path = path;
  info.file_bytes = std::filesystem::file_size(path);
  const openvdb::MetaMap::Ptr meta = file.getMetadata();
  if (const auto id = meta->getMetadata<openvdb::StringMetadata>("vdbmap_unit_id")) info.unit_id = id->value();
  const std::filesystem::path exact = TsdfVolume::exactStatePath(path);
  if (std::filesystem::is_regular_file(exact)) {
    try {
      internal::checkVdbFileStructure(exact);
      openvdb::io::File companion(exact.string());
      companion.open(/*delayLoad=*/false);
      info.weight_scale = detail::checkExactCompanion(*meta, *companion.getMetadata(), path, exact);
      info.has_exact_state = true;
    } catch (const openvdb::Exception& e) {
      info.exact_state_problem = "cannot read " + exact.string() + ": " + e.what();
    } catch (const vdbmap::FileError& e) {
      info.exact_state_problem = e.what();
    }
  }
  for (auto it = meta->beginMeta(); it != meta->endMeta(); ++it) info.metadata.emplace_back(it->first, it->second->str());
  const openvdb::GridPtrVecPtr grids = file.getGrids();
  for (const openvdb::GridBase::Ptr& g : *grids) {
    MapFileGrid m;
    m.name = g->getName();
    m.type = g->type();
    m.grid_class = openvdb::GridBase::gridClassToString(g->getGridClass());
    m.active_voxels = g->activeVoxelCount();
    m.memory_bytes = g->memUsage();
    m.voxel_size_m = g->voxelSize()[0];
    m.bbox_index = g->evalActiveVoxelBoundingBox();
    if (auto fg = openvdb::gridPtrCast<openvdb::FloatGrid>(g)) m.leaf_nodes = fg->tree().leafCount();
    if (!m.bbox_index.empty()) {
      m.bbox_min_m = g->indexToWorld(m.bbox_index.min().asVec3d());
      m.bbox_max_m = g->indexToWorld(m.bbox_index.max().asVec3d());
    }
    info.grids.push_back(m);
  }
  return info;
}

}  // namespace

MapFileInfo inspectMapFile(const std::filesystem::path& path) {
  try {
    return inspectOpenedMapFile(path);
  } catch (const openvdb::Exception& e) {
    throw vdbmap::FileError("cannot read map " + path.string() + ": " + e.what());
  }
}

}  // namespace vdbmap
