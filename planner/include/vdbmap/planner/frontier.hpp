// Frontiers: known-free voxels with an unknown face neighbour, grouped into clusters, kept up to
// date incrementally in the region the map reports as changed (FUEL, Zhou et al. 2021, Sect. IV).
//
// Pipeline, as FUEL's frontier finder:
//  1. a voxel is a frontier voxel when it is free and one of its 6 face neighbours is unknown
//     (inside the exploration box, when one is given);
//  2. frontier voxels are grouped into 26-connected components;
//  3. components smaller than min_cluster_size are dropped (kept internally, so they can grow);
//  4. a component wider than split_radius_xy_m around its centroid is split in two along the first
//     principal axis of its horizontal (x, y) spread, recursively: the clusters.
//
// Incremental updates give exactly what detection from scratch gives. A voxel's frontier status
// depends only on itself and its face neighbours, so after the map changed inside the box D only
// voxels in D grown by one can change status, and only components with a voxel in D grown by two
// can gain or lose voxels or merge. update() re-evaluates the first, re-floods the second, and
// leaves every other component (and its clusters, with their ids) untouched. A cluster that comes
// out of the re-flooding with exactly the voxels it had keeps its id too. A cluster is immutable
// under its id, so callers recompute viewpoints and costs only for the ids reported as added.
#pragma once

#include "vdbmap/planner/coord_hash.hpp"
#include "vdbmap/planner/map_query.hpp"

#include <Eigen/Geometry>

#include <cstdint>
#include <map>
#include <optional>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace vdbmap::planner {

using ClusterId = std::uint64_t;

struct FrontierConfig {
  /// FUEL's cluster_min: 26-connected components with fewer frontier voxels are dropped; [1, 1e8]
  int min_cluster_size = 100;
  /// FUEL's cluster_size_xy: a cluster with a voxel farther than this from its centroid in x-y
  /// is split along its principal horizontal axis; (0, 1e4]
  double split_radius_xy_m = 2.0;
  /// FUEL's down_sample: clusters keep one representative voxel per cube of this many voxels a
  /// side, which viewpoint scoring counts; [1, 64]
  int sample_stride_vox = 3;
  /// The exploration box: frontier voxels, and the unknown neighbours that make them frontiers,
  /// have their centres inside it. Unset: no limit.
  std::optional<Eigen::AlignedBox3d> bounds_W;

  /// Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};
using FrontierParams [[deprecated("renamed FrontierConfig")]] = FrontierConfig;

/// One cluster: a set of frontier voxels the planner plans a visit to.
struct FrontierCluster {
  ClusterId id = 0;                      ///< unique over the FrontierMap's life, never reused
  std::vector<openvdb::Coord> voxels;    ///< sorted (openvdb::Coord's order)
  Vec3d centroid_W = Vec3d::Zero();      ///< mean of the voxel centres
  openvdb::CoordBBox bbox;               ///< index-space box around the voxels
  /// One voxel per sample_stride_vox cube (the one nearest the cube's mean), sorted: what
  /// viewpoints are scored on (FUEL's filtered cells).
  std::vector<openvdb::Coord> samples;
  /// Frontier voxels of the 26-connected component the cluster was split from, when the cluster
  /// was made (a cluster kept under its id keeps this value).
  std::size_t component_voxels = 0;
};

/// What one update changed.
struct FrontierUpdate {
  std::vector<ClusterId> removed;      ///< clusters gone (ascending)
  std::vector<ClusterId> added;        ///< clusters new (ascending)
  std::size_t voxels_scanned = 0;      ///< voxels whose frontier status was evaluated
  std::size_t components_reflooded = 0;
  std::size_t frontier_voxels = 0;     ///< frontier voxels in the map after the update
};

/// The offsets of a voxel's 6 face neighbours: the unknown ones make it a frontier voxel.
inline const openvdb::Coord kFaceNeighbours[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};

/// The frontier test of one voxel: free, with a face neighbour that is unknown. With a
/// non-empty `bounds`, the voxel and that neighbour must both lie inside it.
bool isFrontierVoxel(MapReader& reader, const openvdb::Coord& ijk, const openvdb::CoordBBox* bounds = nullptr);

class FrontierMap {
 public:
  explicit FrontierMap(const FrontierConfig& params = {});

  const FrontierConfig& params() const { return params_; }

  /// Refreshes frontiers after the map changed inside the index-space box `dirty` (e.g.
  /// vdbmap::Mapper::takeDirtyRegion(), which includes re-integration and pruning). An empty box
  /// changes nothing. The map must be the same one (same voxel size) on every call.
  FrontierUpdate update(const MapQuery& map, const openvdb::CoordBBox& dirty);
  /// Forgets everything and detects from scratch over the map's known bounds.
  FrontierUpdate rebuild(const MapQuery& map);
  /// Changes params().min_cluster_size without rescanning the map: components that reach the new
  /// size become clusters (added), clusters of components below it are dropped (removed); every
  /// other cluster keeps its id. The clusters are then those a rebuild with the new size would
  /// give. Throws std::invalid_argument when the size is outside [1, 1e8].
  FrontierUpdate setMinClusterSize(const MapQuery& map, int min_cluster_size);

  /// The current clusters, ascending by id.
  const std::vector<FrontierCluster>& clusters() const { return clusters_; }
  /// The cluster with this id, or nullptr.
  const FrontierCluster* find(ClusterId id) const;

  bool isFrontier(const openvdb::Coord& ijk) const { return frontier_voxels_.count(ijk) != 0; }
  std::size_t frontierVoxelCount() const { return frontier_voxels_.size(); }
  /// Components, including those too small to be clusters.
  std::size_t componentCount() const { return components_.size(); }

 private:
  using ComponentId = std::uint64_t;
  struct Component {
    std::vector<openvdb::Coord> voxels;  ///< sorted
    openvdb::CoordBBox bbox;
    std::vector<ClusterId> clusters;
  };

  openvdb::CoordBBox boundsIndex(const MapQuery& map) const;
  /// The frontier voxels inside `box`, sorted.
  std::vector<openvdb::Coord> scanFrontiers(const MapQuery& map, const openvdb::CoordBBox& box) const;
  /// Groups `pending` (frontier voxels in no component) into 26-connected components with fresh ids.
  /// Sorted input (as both callers pass) is not sorted again.
  void floodComponents(std::vector<openvdb::Coord> pending);
  /// Clusters being taken apart, by their first voxel (an id set to 0 once reused).
  using ReusableClusters = std::map<openvdb::Coord, std::vector<ClusterId>>;
  /// Filters and splits a component into clusters; a piece identical to a reusable cluster keeps
  /// that cluster. New ids are appended to `added`.
  std::vector<ClusterId> makeClusters(const MapQuery& map, const std::vector<openvdb::Coord>& voxels,
                                      ReusableClusters* reusable, std::vector<ClusterId>* added);
  void checkVoxelSize(const MapQuery& map);
  /// Removes these clusters (ids ascending) from clusters_.
  void dropClusters(const std::vector<ClusterId>& sorted_ids);

  FrontierConfig params_;
  double voxel_size_m_ = 0.0;  ///< of the map seen first (0 before)
  /// Every frontier voxel (of some component); an update changes it inside its scan only.
  std::unordered_set<openvdb::Coord, CoordHash> frontier_voxels_;
  std::map<ComponentId, Component> components_;
  std::vector<FrontierCluster> clusters_;
  ComponentId next_component_ = 1;
  ClusterId next_cluster_ = 1;
};

}  // namespace vdbmap::planner
