// The TSDF map: OpenVDB grids of exact fixed-point sums, with integration and exact
// de-integration of frames.
//
// Per voxel the map holds two 64-bit integers: the weight sum W and the weighted signed-distance
// sum WD, both in fixed point (vdbmap/voxel_codec.hpp); and, beside them, how many surface end
// points fell in the voxel (its hits), which keeps structures thinner than a voxel visible. Integer addition is exact and
// commutative, so integrating a frame and then de-integrating it restores every voxel bit for bit,
// and neither the order of frames nor the number of threads changes the map. Voxels whose weight
// returns to zero are removed, so the tree shrinks back.
//
// Voxel centres follow OpenVDB's convention: voxel (i, j, k) is centred at (i, j, k) * voxel_size.
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/config.hpp"
#include "vdbmap/openvdb.hpp"
#include "vdbmap/sensor_frame.hpp"
#include "vdbmap/types.hpp"
#include "vdbmap/voxel_codec.hpp"
#include "vdbmap/voxel_footprint.hpp"

#include <filesystem>
#include <map>
#include <optional>
#include <string>

namespace vdbmap {

class AtomicFileSet;

/// What one call of integrate() or deintegrate() did with its points.
struct IntegrationStats {
  std::size_t points_total = 0;
  /// NaN, infinite, zero, or closer than min_range_m; also points whose weight rounds to 0, which
  /// happens only with a TsdfConfig::weight_scale set too small for max_range_m, or in a map saved
  /// before the scale followed the range.
  std::size_t points_invalid = 0;
  std::size_t points_beyond_range = 0; ///< beyond max_range_m: carved free space only
  std::size_t rays_cast = 0;           ///< after bundling (Merged) or one per valid point (PerRay); 0 (Projective)
  std::size_t voxel_updates = 0;       ///< voxel visits summed over all rays
  openvdb::CoordBBox touched_voxels;   ///< index-space box around every voxel the rays touched
};

/// The largest sensor position coordinate a frame may have, in metres (100 km): beyond it a pose
/// is refused (FrameError) rather than integrated with overflowing voxel coordinates.
inline constexpr double kMaxAbsPosition_m = 1e5;

/// Why the map refuses a frame in integrate() / deintegrate(). Misuse, so an exception.
class FrameError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

class TsdfVolume {
 public:
  using Int64GridT = openvdb::Int64Grid;

  explicit TsdfVolume(const TsdfConfig& config = {}, const IntegratorConfig& integrator = {});
  /// Copies are deep: a copy owns its grids, so changing one map never changes the other.
  TsdfVolume(const TsdfVolume& other);
  TsdfVolume& operator=(const TsdfVolume& other);
  TsdfVolume(TsdfVolume&&) = default;
  TsdfVolume& operator=(TsdfVolume&&) = default;

  const TsdfConfig& config() const { return config_; }
  const IntegratorConfig& integratorConfig() const { return integrator_; }
  /// Changes only the thread count (the map does not depend on it).
  void setThreads(int threads);

  /// Integrates a frame: points in the sensor frame S (NaN/zero points are skipped and counted)
  /// seen from the sensor pose T_W_S. Throws FrameError when `id` is already integrated or the
  /// pose is not a rigid transform; nothing is changed then.
  IntegrationStats integrate(FrameId id, const PointCloud& points_S, const Pose3d& T_W_S);

  /// Removes exactly what integrate(id, points_S, T_W_S) added. Throws FrameError, changing
  /// nothing, when `id` was never integrated or was integrated with other points or pose.
  IntegrationStats deintegrate(FrameId id, const PointCloud& points_S, const Pose3d& T_W_S);

  /// Integrates a depth image (metres along the optical axis; 0 or NaN = invalid) seen with
  /// intrinsics K from T_W_S: projectively with RayMode::Projective, else as its back-projected
  /// points. Throws FrameError as integrate() does, std::invalid_argument when the image size
  /// differs from K.
  /// `footprint`, when given, receives the voxels updated (projective integration; left empty
  /// under the ray modes): the frame's view for set cover (footprintCells), with no second pass.
  IntegrationStats integrate(FrameId id, const DepthImage& depth_m, const CameraIntrinsics& K, const Pose3d& T_W_S,
                             VoxelFootprint* footprint = nullptr);
  /// Removes exactly what integrate(id, depth_m, K, T_W_S) added (same checks as above).
  IntegrationStats deintegrate(FrameId id, const DepthImage& depth_m, const CameraIntrinsics& K, const Pose3d& T_W_S);

  /// Moves an integrated frame from T_W_S_old to T_W_S_new: exactly deintegrate at the old pose
  /// then integrate at the new one (the map ends bit-identical to that), in one pass where the
  /// integrator allows (projective: pixels classified once, only the net change applied). Throws
  /// FrameError, changing nothing, when the frame is not integrated with these data at
  /// T_W_S_old or T_W_S_new is not a rigid transform.
  IntegrationStats reintegrate(FrameId id, const PointCloud& points_S, const Pose3d& T_W_S_old,
                               const Pose3d& T_W_S_new);
  /// `footprint` as for integrate(), at the new pose.
  IntegrationStats reintegrate(FrameId id, const DepthImage& depth_m, const CameraIntrinsics& K,
                               const Pose3d& T_W_S_old, const Pose3d& T_W_S_new, VoxelFootprint* footprint = nullptr);

  /// The calls above for either kind of frame: a depth image with its camera, or points
  /// (`footprint` filled for depth images under projective integration only).
  IntegrationStats integrate(FrameId id, const SensorFrame& frame, const Pose3d& T_W_S,
                             VoxelFootprint* footprint = nullptr);
  IntegrationStats deintegrate(FrameId id, const SensorFrame& frame, const Pose3d& T_W_S);
  IntegrationStats reintegrate(FrameId id, const SensorFrame& frame, const Pose3d& T_W_S_old, const Pose3d& T_W_S_new,
                               VoxelFootprint* footprint = nullptr);

  bool isIntegrated(FrameId id) const { return frames_.count(id) != 0; }
  std::size_t frameCount() const { return frames_.size(); }
  /// The pose each integrated frame was integrated with, by id.
  std::map<FrameId, Pose3d> integratedPoses() const;

  // ---- queries -------------------------------------------------------------------------------
  VoxelSample sample(const openvdb::Coord& ijk) const;
  /// The voxel whose centre is nearest to p_W.
  VoxelSample sampleAt(const Vec3d& p_W) const { return sample(worldToVoxel(p_W)); }
  VoxelState state(const openvdb::Coord& ijk) const { return sample(ijk).state; }
  VoxelState stateAt(const Vec3d& p_W) const { return sample(worldToVoxel(p_W)).state; }
  openvdb::Coord worldToVoxel(const Vec3d& p_W) const;
  Vec3d voxelCenter(const openvdb::Coord& ijk) const;

  /// Number of voxels with any weight (known or not).
  std::size_t activeVoxelCount() const { return weight_q_->activeVoxelCount(); }
  /// Memory of the exact state in bytes (the three trees).
  std::size_t memoryBytes() const { return weight_q_->memUsage() + wsdf_q_->memUsage() + hits_->memUsage(); }
  /// Index-space bounding box of voxels with any weight (empty when the map is empty).
  openvdb::CoordBBox activeBoundingBox() const;

  // ---- exports -------------------------------------------------------------------------------
  /// Known voxels' tsdf in metres (FloatGrid "tsdf", background +truncation, level-set class).
  openvdb::FloatGrid::Ptr tsdfGrid() const;
  /// Known voxels' weight sums (FloatGrid "weight", background 0).
  openvdb::FloatGrid::Ptr weightGrid() const;
  /// The exact state (read-only views; copy before modifying).
  openvdb::Int64Grid::ConstPtr weightSumGrid() const { return weight_q_; }
  openvdb::Int64Grid::ConstPtr weightedSdfSumGrid() const { return wsdf_q_; }
  /// Surface end points per voxel (Int64Grid "hits", background 0; see VoxelSample::hits).
  openvdb::Int64Grid::ConstPtr hitCountGrid() const { return hits_; }

  /// True when both maps hold bit-identical exact state (values and topology, hit counts included).
  bool exactlyEquals(const TsdfVolume& other) const;

  // ---- files (implemented in tsdf_volume_io.cpp) ---------------------------------------------
  /// Writes `path` (.vdb: float grids "tsdf" and "weight" plus metadata, readable by vdb_print
  /// and pyopenvdb) and the exact integer state with the frame registry to exactStatePath(path).
  /// Both are written as one AtomicFileSet under a fresh unit id: a failure leaves existing files
  /// untouched. Throws FileError for a name ending in .exact.vdb (a companion's name).
  void save(const std::filesystem::path& path) const;
  /// save() into a set the caller commits, e.g. with more files of the same unit (Mapper::save).
  void stageSave(const std::filesystem::path& path, AtomicFileSet& files) const;
  /// Loads a map saved by save(). With the companion file the state is exact and integration can
  /// resume bit for bit; without it the state is rebuilt from the float grids (approximately) and
  /// the frame registry is empty. Throws FileError naming the file on bad input, and naming both
  /// files when the companion is of another save (another unit id or map settings).
  static TsdfVolume load(const std::filesystem::path& path);
  /// The unit id the map file at `path` was saved under ("" for maps of format 3 and older).
  static std::string savedUnitId(const std::filesystem::path& path);
  /// A map rebuilt from float sums: `weight` (ray units) and `weighted_tsdf` (weight x tsdf in
  /// metres) on the same voxels, e.g. the fusion of submaps. The state is approximate (quantized
  /// from floats, hasExactState() false) and the frame registry is empty. Throws
  /// std::invalid_argument naming the voxel when a weight is not finite or above 2^30, or a sum
  /// is not finite.
  static TsdfVolume fromWeightedSums(const TsdfConfig& config, const IntegratorConfig& integrator,
                                     const openvdb::FloatGrid& weight, const openvdb::FloatGrid& weighted_tsdf);
  /// `map.vdb` -> `map.exact.vdb`.
  static std::filesystem::path exactStatePath(const std::filesystem::path& path);
  /// Whether `path` has a companion's name (ends in .exact.vdb).
  static bool isExactStatePath(const std::filesystem::path& path);
  /// Whether the state came from exact data (false after loading a map without its companion).
  bool hasExactState() const { return exact_state_; }

 private:
  struct FrameRecord {
    std::uint64_t fingerprint = 0;
    Pose3d T_W_S = Pose3d::Identity();
  };
  IntegrationStats apply(const PointCloud& points_S, const Pose3d& T_W_S, std::int64_t sign);
  IntegrationStats apply(const DepthImage& depth_m, const CameraIntrinsics& K, const Pose3d& T_W_S, std::int64_t sign,
                         VoxelFootprint* footprint = nullptr);
  /// Throws FrameError unless T_W_S is a rigid transform within the map's range.
  void checkPose(FrameId id, const Pose3d& T_W_S, const char* what) const;
  /// Throws FrameError unless `id` is new and T_W_S passes checkPose.
  void checkNewFrame(FrameId id, const Pose3d& T_W_S) const;
  /// Throws FrameError naming the estimate when integrating the frame could need more map memory
  /// than the machine has available (a voxel size far too small for the frame's reach).
  void checkFrameMemory(FrameId id, const PointCloud& points_S) const;
  void checkFrameMemory(FrameId id, const DepthImage& depth_m, const CameraIntrinsics& K) const;
  /// Throws FrameError unless `id` is integrated with this fingerprint; returns its record.
  std::map<FrameId, FrameRecord>::iterator checkKnownFrame(FrameId id, std::uint64_t fingerprint, const char* what);

  TsdfConfig config_;
  IntegratorConfig integrator_;
  openvdb::math::Transform::Ptr transform_;
  Int64GridT::Ptr weight_q_;  ///< W in units of 1 / kWeightScale
  Int64GridT::Ptr wsdf_q_;    ///< WD in units of truncation / (kWeightScale * kSdfScale)
  Int64GridT::Ptr hits_;      ///< surface end points per voxel
  std::map<FrameId, FrameRecord> frames_;
  bool exact_state_ = true;
};

}  // namespace vdbmap
