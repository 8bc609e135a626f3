// The last few seconds of depth frames, as a drift-free view of the vehicle's surroundings.
//
// The global map holds every surface where the pose estimate put it when it was seen: under
// drift, a wall seen a minute ago may sit half a metre from where it is now relative to the
// vehicle, and the map reads the space in between as free. Frames from the last window_s seconds
// agree far better with the vehicle's current estimate, so they tell what is really near the
// vehicle now:
//  - surfaces: every recent frame's surface points, as the voxels that hold them
//    (surfaceVoxels()); a voxel a recent frame saw a surface in is an obstacle, whatever the
//    global map says (recent_obstacle_map.hpp). With newer_free_clears, the newest observation
//    of a voxel wins, as free-space ray casting clears an occupancy grid: a surface voxel whose
//    centre and eight corners a newer frame saw free (seesFree's test, that frame alone) is no
//    longer one. Within a window drift still moves: at s3 a biased velocity of about 4 cm/s
//    shifts the frames of 10 s by some 0.4 m, and a door jamb seen early in the window, kept
//    where that frame put it, narrowed a door that the newest frames saw open
//    (docs/exploration.md, "Stop 65");
//  - free space: a point is seen free when a recent frame's ray through it ends on a surface at
//    least free_margin_m beyond it, within max_range_m (seesFree()); a point no recent frame saw
//    free is not trusted for flight near the vehicle, even where the global map calls it free.
//
// Frames are stored small: each block of pool_px x pool_px pixels keeps its nearest valid depth
// (min pooling), so that a block reads as free only up to its nearest surface, and that nearest
// pixel's point as the block's surface point (exactly on the surface; at 4 px and 387 px focal
// length, blocks are 1 cm wide per metre of range). Poses are in the frame of the vehicle's estimate; shift() moves
// them with it when a loop closure re-anchors the estimate, so the recent frames stay consistent with each other and
// with the vehicle.
//
// Not thread-safe; reading (seesFree) from several threads at once is fine between changes.
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/planner/coord_hash.hpp"
#include "vdbmap/planner/surface_index.hpp"
#include "vdbmap/types.hpp"

#include <openvdb/Types.h>

#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <deque>
#include <limits>
#include <unordered_map>
#include <vector>

namespace vdbmap::planner {

struct RecentFramesConfig {
  /// Frames older than this (behind the newest frame's time) are forgotten; (0, 600]. At the
  /// paper's strongest drift (s4) 10 s of odometry move a frame by about 6 cm per axis and
  /// 0.08 rad (one sigma), within the margins near the vehicle; shorter windows forget the way
  /// back that the vehicle just flew, and make it turn to look again.
  double window_s = 10.0;
  /// Frames this recent are all kept; older ones (in a window longer than this) one per
  /// sparse_period_s, since neighbouring frames see nearly the same: a 60 s window at 15 Hz keeps
  /// 250 frames instead of 900 (the manager sets it to SafetyConfig's recent.window_s); (0, 600]
  double dense_s = 10.0;
  /// The spacing of the frames kept older than dense_s; [0, 60]
  double sparse_period_s = 0.5;
  /// Side of the pixel blocks depth is pooled over; [1, 64]
  int pool_px = 4;
  /// Surfaces farther than this are not kept, and points farther than this are never seen free
  /// (the camera's trusted range); (0, 1000]
  double max_range_m = 4.5;
  /// A point is seen free when the surface behind it along the ray is at least this much farther
  /// (the vehicle's radius: its body, not only its centre, must fit in front of the surface); [0, 10]
  double free_margin_m = 0.15;
  /// A surface voxel that a newer frame saw free, centre and corners, is no longer a surface (the
  /// header comment); false: every kept frame's surface voxels count.
  bool newer_free_clears = true;

  void validate() const;
};

/// Voxels holding a recent surface point, with the number of recent frames that saw one there
/// (since a newer frame last saw the voxel free, RecentFramesConfig::newer_free_clears).
using SurfaceVoxels = std::unordered_map<openvdb::Coord, int, CoordHash>;

class RecentFrames {
 public:
  /// Throws std::invalid_argument for an invalid config.
  explicit RecentFrames(const RecentFramesConfig& config = {});

  const RecentFramesConfig& config() const { return config_; }

  /// Adds a frame captured at t_s with the sensor pose T_W_S (estimate frame), forgets the
  /// frames older than t_s - window_s and thins those older than t_s - dense_s (config). Throws
  /// std::invalid_argument when t_s goes back in time, the image's size differs from K's, or the
  /// pose is not finite.
  void add(double t_s, const DepthImage& depth, const CameraIntrinsics& K, const Pose3d& T_W_S);

  /// The estimate frame moved: a pose P in the old frame is now shift * P (every stored frame moves).
  void shift(const Eigen::Isometry3d& shift);

  /// Forgets every frame.
  void clear();

  std::size_t size() const { return frames_.size(); }
  /// The kept frames' capture times, oldest first.
  std::vector<double> frameTimes() const;
  bool empty() const { return frames_.empty(); }

  /// True when some recent frame captured at or after since_t_s saw p_W free (see the header
  /// comment).
  bool seesFree(const Vec3d& p_W, double since_t_s = -std::numeric_limits<double>::infinity()) const;
  /// A box that holds every point seesFree() can be true for: the frames' origins grown by
  /// max_range_m (empty without frames).
  Eigen::AlignedBox3d reach_W() const;

  /// The voxels (of size voxel_size_m, OpenVDB's convention) that hold a surface point of a recent
  /// frame, with newer_free_clears those that no frame added after it saw free (the header
  /// comment). Kept up to date incrementally between calls with the same voxel size, the first
  /// call (or a new size, or shift()) counting the kept frames oldest first; valid until the next
  /// non-const call. With newer_free_clears a frame dropped by thinning (dense_s) still cleared
  /// what it saw free while it was the newest, until the next recount.
  const SurfaceVoxels& surfaceVoxels(double voxel_size_m);
  /// The same voxels as surfaceVoxels(voxel_size_m), brought up to date as that does, as an index
  /// (for lookups); valid until the next non-const call.
  const SurfaceIndex& surfaceIndex(double voxel_size_m) {
    surfaceVoxels(voxel_size_m);
    return index_;
  }

 private:
  struct Frame {
    double t_s = 0.0;
    std::uint64_t seq = 0;  ///< the order frames were added in
    Pose3d T_W_S = Pose3d::Identity();
    Pose3d T_S_W = Pose3d::Identity();
    int width = 0, height = 0;                      ///< in blocks
    double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;  ///< of the pooled image (block units)
    std::vector<float> depth_m;                     ///< nearest valid depth per block; 0: none
    std::vector<Vec3f> surface_S;                   ///< each block's nearest point within max_range_m, sensor frame
    std::vector<openvdb::Coord> voxels;             ///< distinct voxels of surface_S (when counted)
    bool counted = false;                           ///< voxels are in voxels_
  };
  /// seesFree's test for one frame.
  bool frameSeesFree(const Frame& frame, const Vec3d& p_W) const;
  /// The frame sees the voxel's centre and its eight corners free: the whole voxel lies in front of
  /// what the frame saw. (Its centre alone is seen free along a surface seen at a grazing angle:
  /// a ray through a centre 5 cm in front of a ceiling seen 11 degrees off it runs 0.25 m further
  /// before it meets the ceiling.)
  bool frameSeesVoxelFree(const Frame& frame, const openvdb::Coord& ijk) const;
  /// Counts the frame's surface voxels, after (newer_free_clears) clearing those counted so far
  /// that it sees free: the frame must be newer than every frame counted.
  void count(Frame& frame);
  void uncount(Frame& frame);
  /// Counts every kept frame afresh, oldest first.
  void recount();

  RecentFramesConfig config_;
  std::deque<Frame> frames_;  ///< oldest first
  /// Voxel -> the number of counted frames that saw a surface in it after its clearing time.
  SurfaceVoxels voxels_;
  SurfaceIndex index_;  ///< the voxels of voxels_
  /// Voxel -> the seq of the newest frame that saw it free while it held a surface; a frame added
  /// before that one no longer counts there. Forgotten once no such frame is kept.
  std::unordered_map<openvdb::Coord, std::uint64_t, CoordHash> cleared_;
  std::uint64_t next_seq_ = 0;
  double voxel_size_m_ = 0.0;  ///< of voxels_ (0: none counted yet)
};

}  // namespace vdbmap::planner
