// ROS1 bags as frame sources, read through ROS's own rosbag_storage (Debian's packages; no ROS
// master, no catkin): depth images, the camera's intrinsics, poses and loop-closure corrections.
//
// - Depth: sensor_msgs/Image in 16UC1 (millimetres, 0 invalid) or 32FC1 (metres, NaN or 0
//   invalid), stamped by header.stamp (strictly increasing).
// - Intrinsics: the first sensor_msgs/CameraInfo (K); a distortion model other than none, or a
//   plumb_bob / rational_polynomial with non-zero coefficients, is refused.
// - Poses: nav_msgs/Odometry, geometry_msgs/PoseStamped or geometry_msgs/TransformStamped body
//   poses T_W_B (strictly increasing stamps), interpolated at each depth stamp (linear + slerp);
//   the camera pose is T_W_B x T_B_S (the extrinsic, identity by default). A depth frame outside
//   the pose stream's span is skipped and counted.
// - Corrections: each nav_msgs/Path message is one correction event at its header.stamp holding
//   corrected body poses of a subset of stamps (e.g. VINS-Fusion's loop_fusion keyframes); it
//   applies after the last depth frame at or before that stamp, to every frame up to it
//   (pose_interpolation.hpp). Poses outside the frames up to the event are left out and counted.
// - Unset topics are picked when the bag holds exactly one topic of the kind. Messages of an
//   unknown encoding or type are errors naming the topic and the stamp; bz2 and lz4 chunks read
//   as plain ones.
#pragma once

#include "vdbmap/io/frame_source.hpp"

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace vdbmap::io {

/// Whether this build reads bags (Debian's librosbag-storage-dev was found).
bool rosBagSupport();

struct RosBagTopic {
  std::string name;
  std::string type;          ///< e.g. sensor_msgs/Image
  std::size_t messages = 0;
  double first_s = 0.0, last_s = 0.0;  ///< bag receive times
};

struct RosBagInfo {
  std::vector<RosBagTopic> topics;  ///< by name
  double start_s = 0.0, end_s = 0.0;
  std::size_t messages = 0;
};

/// The topics, types, counts and time span of a bag. Throws FileError naming the file for a
/// missing, truncated or malformed bag, or a build without bag support.
RosBagInfo inspectRosBag(const std::filesystem::path& bag);

struct RosBagConfig {
  std::string depth_topic;        ///< empty: the bag's only sensor_msgs/Image topic
  std::string camera_info_topic;  ///< empty: the only sensor_msgs/CameraInfo topic
  std::string pose_topic;         ///< empty: the only Odometry, PoseStamped or TransformStamped topic
  std::string corrections_topic;  ///< empty: the only nav_msgs/Path topic, if any ("-": none)
  Pose3d T_B_S = Pose3d::Identity();  ///< the extrinsic: camera pose = body pose x T_B_S
  double min_range_m = 0.1;       ///< the sensor's, as in sensor.json
  double max_range_m = 5.0;

  void validate() const;
};
using RosBagOptions [[deprecated("renamed RosBagConfig")]] = RosBagConfig;

/// The bag as a frame source (format "rosbag"): frames loaded from the bag on demand (thread-safe).
/// Throws FileError (std::runtime_error) naming the file, topic and stamp for a missing topic, a
/// missing CameraInfo, an unknown encoding or message type, non-increasing stamps, no frame in the
/// pose stream's span, or a bag that cannot be read.
std::unique_ptr<FrameSource> openRosBag(const std::filesystem::path& bag, const RosBagConfig& options = {});

}  // namespace vdbmap::io
