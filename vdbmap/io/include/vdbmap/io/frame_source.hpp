// A uniform, random-access view of a recorded sequence: our log format or an imported dataset
// layout (7-Scenes, 3DMatch, ICL-NUIM, Redwood, TUM RGB-D, Replica), auto-detected. See
// docs/formats.md.
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/io/errors.hpp"
#include "vdbmap/io/sensor_info.hpp"
#include "vdbmap/io/tum_trajectory.hpp"
#include "vdbmap/sensor_frame.hpp"
#include "vdbmap/types.hpp"

#include <cstddef>
#include <filesystem>
#include <memory>
#include "vdbmap/io/timestamps.hpp"

#include <optional>
#include <string>
#include <vector>

namespace vdbmap::io {

/// Datasets without timestamps get timestamp = frame number / this rate (the Kinect-style
/// 30 Hz of 7-Scenes, ICL-NUIM, Redwood and SUN3D; a nominal clock for Replica renders).
constexpr double kNominalFrameRateHz = 30.0;

/// One frame as listed (no pixel or point read yet).
struct FrameRecord {
  std::size_t index = 0;       ///< position in the sequence, 0-based
  double timestamp_s = 0.0;    ///< strictly increasing over the sequence
  std::filesystem::path file;  ///< depth PNG, or .ply/.pcd/.bin points; absolute or relative to the working dir
  Pose3d T_W_S = Pose3d::Identity();  ///< the pose the dataset gives (odometry in logs, ground truth in most datasets)
  std::string source;          ///< where the frame was listed, e.g. "log/frames.csv:13"
  std::string problem;         ///< non-empty: the frame is unusable and load() throws BadFrameError with it
};

/// One loaded frame: a depth image (metres) with the sensor's camera, or points in the sensor
/// frame, with its pose.
struct Frame {
  std::size_t index = 0;
  double timestamp_s = 0.0;
  Pose3d T_W_S = Pose3d::Identity();
  SensorFrame data;
};

/// A loop-closure correction: optimised poses the SLAM back end published at event_timestamp_s;
/// they apply once the frame with that timestamp has been integrated, to every frame integrated
/// by then (io/pose_interpolation.hpp: applyCorrection interpolates between the listed stamps).
struct CorrectionEvent {
  double event_timestamp_s = 0.0;
  std::size_t event_frame = 0;              ///< index of the frame at event_timestamp_s
  /// Corrected T_W_S at any stamps (increasing) within the frames up to the event; a stamp that
  /// matches a frame's is that frame's exactly.
  std::vector<StampedPose> poses;
  std::filesystem::path file;               ///< corrections/<event_timestamp>.txt
};

/// Everything a FrameSource lists; importers fill it.
struct FrameSourceContents {
  std::string format;           ///< "log", "7scenes", "3dmatch", "iclnuim", "redwood", "tum", "replica"
  std::filesystem::path root;   ///< the folder the sequence was read from
  SensorInfo sensor;
  std::vector<FrameRecord> records;
  std::vector<CorrectionEvent> corrections;
  std::vector<StampedPose> ground_truth;  ///< optional; for evaluation only
  std::string description;      ///< where intrinsics, depth scale and poses came from
};

class FrameSource {
 public:
  /// Checks that indices are 0..n-1 and timestamps strictly increase (std::invalid_argument).
  explicit FrameSource(FrameSourceContents contents);
  virtual ~FrameSource() = default;

  const std::string& format() const { return c_.format; }
  const std::filesystem::path& root() const { return c_.root; }
  const std::string& description() const { return c_.description; }
  const SensorInfo& sensor() const { return c_.sensor; }
  /// The depth sensor's camera, one for all frames (nullptr for point sensors).
  const std::shared_ptr<const CameraIntrinsics>& sharedIntrinsics() const { return K_; }
  std::size_t size() const { return c_.records.size(); }
  /// Throws std::out_of_range when i >= size().
  const FrameRecord& record(std::size_t i) const;
  const std::vector<FrameRecord>& records() const { return c_.records; }

  /// Reads frame i. Throws BadFrameError (for frame i only) when its file is missing, corrupt,
  /// of the wrong kind or size, or its listed pose was invalid; std::out_of_range when
  /// i >= size(). Thread-safe: frames may be loaded in parallel.
  virtual Frame load(std::size_t i) const;

  /// Correction events sorted by event time (empty for datasets without corrections/).
  const std::vector<CorrectionEvent>& corrections() const { return c_.corrections; }
  /// True poses when the dataset has them separately (groundtruth.txt), else empty.
  const std::vector<StampedPose>& groundTruth() const { return c_.ground_truth; }

  /// The frame whose timestamp is within `tolerance_s` of `timestamp_s`, if any.
  std::optional<std::size_t> findFrame(double timestamp_s, double tolerance_s = kTimestampMatchTolerance_s) const;

 private:
  FrameSourceContents c_;
  std::shared_ptr<const CameraIntrinsics> K_;
};

/// The dataset layouts openDataset knows.
enum class DatasetFormat { Auto, Log, SevenScenes, ThreeDMatch, IclNuim, Redwood, Tum, Replica };

/// "auto", "log", "7scenes", "3dmatch", "iclnuim", "redwood", "tum", "replica".
const char* toString(DatasetFormat format);
/// Inverse of toString; throws std::invalid_argument listing the accepted names.
DatasetFormat parseDatasetFormat(const std::string& name);

/// Which layout `path` holds, or Auto when none is recognised (no exception).
DatasetFormat detectDatasetFormat(const std::filesystem::path& path);

/// Opens a log or dataset folder in place. With Auto the layout is detected; otherwise it is
/// forced. Throws std::runtime_error naming the file and line for a missing folder, missing or
/// malformed listing files, timestamps out of order, or a correction that names no frame.
/// Per-frame problems (invalid pose, missing frame file) do not fail the listing: the record
/// carries them and load(i) throws BadFrameError.
std::unique_ptr<FrameSource> openDataset(const std::filesystem::path& path, DatasetFormat format = DatasetFormat::Auto);

}  // namespace vdbmap::io
