// Importers of public RGB-D dataset layouts, read in place. Intrinsics, depth scale and pose
// convention come from the dataset's own files where it has them; where a dataset family does
// not ship them, the family's documented convention is used (and said in the description).
// Nothing depends on a folder's name.
#include "importers.hpp"

#include "vdbmap/io/pose_interpolation.hpp"

#include "vdbmap/io/errors.hpp"
#include "vdbmap/io/png_io.hpp"

#include "pose_util.hpp"
#include "text_util.hpp"

#include <nlohmann/json.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <regex>
#include <sstream>

namespace vdbmap::io::detail {
namespace {

namespace fs = std::filesystem;

bool isDir(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}
bool isFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

/// Files in `dir` whose name matches `re`, sorted by name; the first capture group is returned
/// as a number in `numbers` when given.
std::vector<fs::path> listMatching(const fs::path& dir, const std::regex& re, std::vector<long long>* numbers = nullptr) {
  std::vector<std::pair<std::string, fs::path>> found;
  std::error_code ec;
  if (!isDir(dir)) return {};
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (std::regex_match(name, re)) found.emplace_back(name, e.path());
  }
  std::sort(found.begin(), found.end());
  std::vector<fs::path> out;
  if (numbers) numbers->clear();
  for (auto& [name, p] : found) {
    if (numbers) {
      std::smatch m;
      std::regex_match(name, m, re);
      // The digits are the file's name: "frame-99999999999999999999.depth.png" does not fit a
      // long long, which std::stoll reports with std::out_of_range; a bad file name is bad input.
      const std::string digits = m[1].str();
      long long number = 0;
      const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), number);
      if (ec != std::errc() || end != digits.data() + digits.size())
        fail(p, "frame number " + quoteToken(digits) + " in the file name is not an integer below 2^63");
      numbers->push_back(number);
    }
    out.push_back(p);
  }
  return out;
}

/// Reads `count` whitespace-separated numbers (e.g. a 3x3 or 4x4 matrix) ignoring '#' comments.
std::vector<double> readNumbers(const fs::path& path, std::size_t count) {
  const std::string text = readWholeFile(path);
  LineReader lines(text);
  std::string_view line;
  std::vector<std::string_view> tok;
  std::vector<double> values;
  while (lines.next(line)) {
    const std::size_t hash = line.find('#');
    if (hash != std::string_view::npos) line = line.substr(0, hash);
    splitWhitespace(line, tok);
    for (std::string_view t : tok) {
      double v;
      if (!parseDouble(t, v)) failAt(path, lines.lineNumber(), "not a number: " + quoteToken(t));
      values.push_back(v);
    }
  }
  if (values.size() != count)
    fail(path, "expected " + std::to_string(count) + " numbers, found " + std::to_string(values.size()));
  return values;
}

/// fx, fy, cx, cy from a 3x3 camera matrix file (7-Scenes / 3DMatch camera-intrinsics.txt).
void readK3x3(const fs::path& path, CameraIntrinsics& K) {
  const std::vector<double> m = readNumbers(path, 9);
  if (m[1] != 0.0 || m[3] != 0.0 || m[6] != 0.0 || m[7] != 0.0 || m[8] != 1.0)
    fail(path, "expected a pinhole camera matrix [fx 0 cx; 0 fy cy; 0 0 1]");
  K.fx = m[0];
  K.cx = m[2];
  K.fy = m[4];
  K.cy = m[5];
}

/// Sets the image size from the first readable frame's PNG header; keeps the defaults otherwise.
void imageSizeFromFrames(const std::vector<FrameRecord>& records, CameraIntrinsics& K) {
  for (const FrameRecord& r : records) {
    try {
      readPngSize(r.file, K.width, K.height);
      return;
    } catch (const std::runtime_error&) {
    }
  }
}

std::string relTo(const fs::path& p, const fs::path& base) {
  std::error_code ec;
  const fs::path r = fs::relative(p, base, ec);
  return ec || r.empty() ? p.string() : r.string();
}

// ---- 7-Scenes / 3DMatch --------------------------------------------------------------------

const std::regex& depthFrameRe() {
  static const std::regex re("frame-([0-9]+)\\.depth\\.png");
  return re;
}

bool hasSevenScenesFrames(const fs::path& dir) { return !listMatching(dir, depthFrameRe()).empty(); }

}  // namespace

FrameSourceContents importSevenScenes(const fs::path& folder, DatasetFormat as) {
  // Two arrangements: frames and poses side by side (7-Scenes / 3DMatch seq-XX folders), or
  // depth/ and pose/ sub-folders (andyzeng/tsdf-fusion-python's copy of 7-Scenes).
  fs::path depth_dir = folder, pose_dir = folder;
  if (!hasSevenScenesFrames(folder) && hasSevenScenesFrames(folder / "depth")) {
    depth_dir = folder / "depth";
    pose_dir = isDir(folder / "pose") ? folder / "pose" : folder / "depth";
  }
  std::vector<long long> numbers;
  const std::vector<fs::path> depth_files = listMatching(depth_dir, depthFrameRe(), &numbers);
  if (depth_files.empty()) fail(folder, "no frame-XXXXXX.depth.png files (7-Scenes / 3DMatch layout)");

  FrameSourceContents c;
  c.format = toString(as);
  c.root = folder;
  SensorInfo& s = c.sensor;
  s.kind = SensorKind::Depth;
  s.depth_scale = 0.001;         // family convention: depth in millimetres
  s.invalid_depth_raw = 65535;   // 7-Scenes marks missing depth with 65535 (and 0)
  // Intrinsics from camera-intrinsics.txt beside the frames or one or two folders up (3DMatch
  // keeps it in the scene folder above seq-XX); else 7-Scenes' documented depth camera.
  std::string k_from;
  for (const fs::path& dir : {folder, depth_dir, folder.parent_path()}) {
    if (isFile(dir / "camera-intrinsics.txt")) {
      readK3x3(dir / "camera-intrinsics.txt", s.intrinsics);
      k_from = (dir / "camera-intrinsics.txt").string();
      break;
    }
  }
  if (k_from.empty()) {
    s.intrinsics.fx = s.intrinsics.fy = 585.0;
    s.intrinsics.cx = 320.0;
    s.intrinsics.cy = 240.0;
    k_from = "7-Scenes' documented depth intrinsics (fx = fy = 585, cx = 320, cy = 240; no camera-intrinsics.txt found)";
  }
  for (std::size_t i = 0; i < depth_files.size(); ++i) {
    FrameRecord r;
    r.index = i;
    r.file = depth_files[i];
    r.timestamp_s = double(numbers[i]) / kNominalFrameRateHz;
    r.source = relTo(depth_files[i], folder);
    char name[64];
    std::snprintf(name, sizeof(name), "frame-%06lld.pose.txt", numbers[i]);
    const fs::path pose_file = pose_dir / name;
    if (!isFile(pose_file)) {
      r.problem = "no pose file " + pose_file.string();
    } else {
      try {
        const std::vector<double> m = readNumbers(pose_file, 16);
        const std::string why = poseFromMatrix(m.data(), 4, r.T_W_S);
        if (!why.empty()) r.problem = pose_file.string() + ": " + why;
      } catch (const std::runtime_error& e) {
        r.problem = e.what();
      }
    }
    c.records.push_back(std::move(r));
  }
  imageSizeFromFrames(c.records, s.intrinsics);
  s.intrinsics.validate();
  c.description = std::string(as == DatasetFormat::ThreeDMatch ? "3DMatch" : "7-Scenes") +
                  " layout: depth in millimetres (0 and 65535 invalid), camera-to-world 4x4 poses from "
                  "frame-XXXXXX.pose.txt, intrinsics from " + k_from + ", timestamp = frame number / 30 Hz";
  return c;
}

namespace {

// ---- Redwood (Open3D .log trajectories) ----------------------------------------------------

/// Poses of a Redwood .log file: per pose a line "i j k" then four rows of a 4x4 camera-to-world
/// matrix. Invalid matrices are returned as problems, not thrown.
void readRedwoodLog(const fs::path& path, std::vector<Pose3d>& poses, std::vector<std::string>& problems) {
  const std::string text = readWholeFile(path);
  LineReader lines(text);
  std::string_view line;
  std::vector<std::string_view> tok;
  auto nextNonEmpty = [&]() {
    while (lines.next(line)) {
      splitWhitespace(line, tok);
      if (!tok.empty()) return true;
    }
    return false;
  };
  while (nextNonEmpty()) {
    const std::size_t header_line = lines.lineNumber();
    if (tok.size() != 3) failAt(path, header_line, "expected a pose header 'i j n' (3 integers)");
    double m[16];
    for (int r = 0; r < 4; ++r) {
      if (!nextNonEmpty()) fail(path, "truncated: the pose that starts on line " + std::to_string(header_line) + " has fewer than 4 rows");
      if (tok.size() != 4) failAt(path, lines.lineNumber(), "expected 4 numbers in a pose matrix row");
      for (int k = 0; k < 4; ++k)
        if (!parseDouble(tok[std::size_t(k)], m[r * 4 + k])) failAt(path, lines.lineNumber(), "not a number: " + quoteToken(tok[std::size_t(k)]));
    }
    Pose3d T = Pose3d::Identity();
    const std::string why = poseFromMatrix(m, 4, T);
    poses.push_back(T);
    problems.push_back(why.empty() ? std::string() : path.string() + ":" + std::to_string(header_line) + ": " + why);
  }
}

/// Open3D's PinholeCameraIntrinsic JSON: width, height and a column-major 3x3 intrinsic_matrix.
bool readOpen3dIntrinsics(const fs::path& path, CameraIntrinsics& K) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(readWholeFile(path));
  } catch (const nlohmann::json::exception& e) {  // parse_error, or out_of_range for "1e1000"
    fail(path, std::string("invalid JSON: ") + e.what());
  }
  if (!j.is_object() || !j.contains("intrinsic_matrix")) return false;
  const auto& m = j["intrinsic_matrix"];
  if (!m.is_array() || m.size() != 9) fail(path, "\"intrinsic_matrix\" must hold 9 numbers (column-major 3x3)");
  for (const auto& v : m)
    if (!v.is_number()) fail(path, "\"intrinsic_matrix\" must hold numbers");
  if (!j.contains("width") || !j.contains("height") || !j["width"].is_number_integer() || !j["height"].is_number_integer())
    fail(path, "missing integer \"width\" / \"height\"");
  K.width = j["width"].get<int>();
  K.height = j["height"].get<int>();
  K.fx = m[0].get<double>();
  K.fy = m[4].get<double>();
  K.cx = m[6].get<double>();
  K.cy = m[7].get<double>();
  return true;
}

}  // namespace

FrameSourceContents importRedwood(const fs::path& folder) {
  FrameSourceContents c;
  c.format = "redwood";
  c.root = folder;
  SensorInfo& s = c.sensor;
  s.kind = SensorKind::Depth;
  s.depth_scale = 0.001;  // Redwood convention: millimetres
  // Depth list: rgbd.match (depth then colour per line) when present, else depth/*.png by name.
  std::vector<fs::path> depth_files;
  if (isFile(folder / "rgbd.match")) {
    const std::string text = readWholeFile(folder / "rgbd.match");
    LineReader lines(text);
    std::string_view line;
    std::vector<std::string_view> tok;
    while (lines.next(line)) {
      splitWhitespace(line, tok);
      if (tok.empty()) continue;
      depth_files.push_back(folder / std::string(tok[0]));
    }
  } else {
    depth_files = listMatching(folder / "depth", std::regex(".*\\.png"));
  }
  if (depth_files.empty()) fail(folder, "no depth images (depth/*.png) in the Redwood layout");
  fs::path log_file = folder / "trajectory.log";
  if (!isFile(log_file)) log_file = folder / "odometry.log";
  if (!isFile(log_file)) fail(folder, "no trajectory.log or odometry.log (Redwood layout)");
  std::vector<Pose3d> poses;
  std::vector<std::string> problems;
  readRedwoodLog(log_file, poses, problems);
  if (poses.size() > depth_files.size())
    fail(log_file, "lists " + std::to_string(poses.size()) + " poses for " + std::to_string(depth_files.size()) + " depth images");
  std::string k_from;
  for (const fs::path& dir : {folder, folder.parent_path()}) {
    if (!k_from.empty() || !isDir(dir)) continue;
    for (const fs::path& json : listMatching(dir, std::regex(".*\\.json"))) {
      if (readOpen3dIntrinsics(json, s.intrinsics)) {
        k_from = json.string();
        break;
      }
    }
  }
  if (k_from.empty()) {
    s.intrinsics = CameraIntrinsics{640, 480, 525.0, 525.0, 319.5, 239.5};
    k_from = "the PrimeSense default of Redwood/Open3D (640x480, fx = fy = 525, cx = 319.5, cy = 239.5; no intrinsics JSON found)";
  }
  s.intrinsics.validate();
  for (std::size_t i = 0; i < depth_files.size(); ++i) {
    FrameRecord r;
    r.index = i;
    r.file = depth_files[i];
    r.timestamp_s = double(i) / kNominalFrameRateHz;
    r.source = relTo(depth_files[i], folder);
    if (i < poses.size()) {
      r.T_W_S = poses[i];
      r.problem = problems[i];
    } else {
      r.problem = "no pose for this frame in " + log_file.string();
    }
    c.records.push_back(std::move(r));
  }
  c.description = "Redwood layout: depth in millimetres, camera-to-world poses from " + log_file.filename().string() +
                  " (the i-th pose for the i-th depth image), intrinsics from " + k_from +
                  ", timestamp = frame index / 30 Hz";
  return c;
}

// ---- ICL-NUIM (slambook2 arrangement) -------------------------------------------------------

FrameSourceContents importIclNuim(const fs::path& folder) {
  FrameSourceContents c;
  c.format = "iclnuim";
  c.root = folder;
  SensorInfo& s = c.sensor;
  s.kind = SensorKind::Depth;
  // ICL-NUIM's documented camera (the files carry none): 640x480, fx = 481.2, fy = -480 (its
  // y axis is flipped), cx = 319.5, cy = 239.5, depth factor 5000.
  s.intrinsics = CameraIntrinsics{640, 480, 481.2, -480.0, 319.5, 239.5};
  s.depth_scale = 1.0 / 5000.0;
  const fs::path pose_file = folder / "pose.txt";
  if (!isFile(pose_file)) fail(pose_file, "no such file");
  const std::string text = readWholeFile(pose_file);
  LineReader lines(text);
  std::string_view line;
  std::vector<std::string_view> tok;
  while (lines.next(line)) {
    const std::string_view t = trim(line);
    if (t.empty() || t.front() == '#') continue;
    const std::size_t ln = lines.lineNumber();
    splitWhitespace(t, tok);
    FrameRecord r;
    r.index = c.records.size();
    // Line k (1-based among pose lines) belongs to depth/k.png.
    r.file = folder / "depth" / (std::to_string(r.index + 1) + ".png");
    r.timestamp_s = double(r.index) / kNominalFrameRateHz;
    r.source = "pose.txt:" + std::to_string(ln);
    if (tok.size() != 7) {
      r.problem = "expected 'tx ty tz qx qy qz qw' (7 numbers), found " + std::to_string(tok.size()) + " fields";
    } else {
      double v[7];
      for (int k = 0; k < 7 && r.problem.empty(); ++k)
        if (!parseDouble(tok[std::size_t(k)], v[k])) r.problem = "not a number: " + quoteToken(tok[std::size_t(k)]);
      if (r.problem.empty()) r.problem = poseFromTum(v, r.T_W_S);
    }
    c.records.push_back(std::move(r));
  }
  if (c.records.empty()) fail(pose_file, "lists no pose");
  c.description = "ICL-NUIM layout (pose.txt + depth/<n>.png): depth factor 5000, camera-to-world poses "
                  "'tx ty tz qx qy qz qw' (line n for depth/n.png), ICL-NUIM's documented intrinsics "
                  "fx = 481.2, fy = -480, cx = 319.5, cy = 239.5, timestamp = frame index / 30 Hz";
  return c;
}

// ---- TUM RGB-D ------------------------------------------------------------------------------

namespace {

/// Maximum gap between a depth timestamp and the ground-truth poses it is interpolated from.
constexpr double kTumMaxPoseGap_s = 0.05;

}  // namespace

FrameSourceContents importTum(const fs::path& folder) {
  FrameSourceContents c;
  c.format = "tum";
  c.root = folder;
  SensorInfo& s = c.sensor;
  s.kind = SensorKind::Depth;
  s.depth_scale = 1.0 / 5000.0;  // TUM RGB-D: depth factor 5000
  std::string k_from;
  if (isFile(folder / "sensor.json")) {
    // An explicit camera in our own format wins (TUM's files do not carry intrinsics).
    s = readSensorJson(folder / "sensor.json");
    k_from = (folder / "sensor.json").string();
  } else {
    s.intrinsics = CameraIntrinsics{640, 480, 525.0, 525.0, 319.5, 239.5};
    k_from = "TUM's documented ROS default (fx = fy = 525, cx = 319.5, cy = 239.5; put a sensor.json beside depth.txt "
             "for the calibrated Freiburg values)";
  }
  const fs::path list = folder / "depth.txt";
  if (!isFile(list)) fail(list, "no such file");
  const fs::path gt_file = folder / "groundtruth.txt";
  std::vector<StampedPose> gt;
  if (isFile(gt_file)) gt = readTumTrajectory(gt_file);
  const std::string text = readWholeFile(list);
  LineReader lines(text);
  std::string_view line;
  std::vector<std::string_view> tok;
  while (lines.next(line)) {
    const std::string_view t = trim(line);
    if (t.empty() || t.front() == '#') continue;
    const std::size_t ln = lines.lineNumber();
    splitWhitespace(t, tok);
    if (tok.size() != 2) failAt(list, ln, "expected 'timestamp filename'");
    FrameRecord r;
    r.index = c.records.size();
    if (!parseDouble(tok[0], r.timestamp_s) || !std::isfinite(r.timestamp_s)) failAt(list, ln, "timestamp " + quoteToken(tok[0]) + " is not a number");
    if (!c.records.empty() && !(r.timestamp_s > c.records.back().timestamp_s))
      failAt(list, ln, "timestamp is not greater than the previous frame's: frames must be in time order");
    r.file = folder / std::string(tok[1]);
    r.source = "depth.txt:" + std::to_string(ln);
    // The pose: linear/slerp interpolation between the bracketing ground-truth poses.
    const auto it = std::lower_bound(gt.begin(), gt.end(), r.timestamp_s,
                                     [](const StampedPose& p, double x) { return p.timestamp_s < x; });
    if (gt.empty()) {
      r.problem = "no groundtruth.txt, so no pose";
    } else if (it != gt.end() && std::abs(it->timestamp_s - r.timestamp_s) < 1e-9) {
      r.T_W_S = it->T_W_S;
    } else if (it == gt.begin() || it == gt.end() || it->timestamp_s - (it - 1)->timestamp_s > kTumMaxPoseGap_s) {
      r.problem = "no ground-truth poses within " + std::to_string(kTumMaxPoseGap_s) + " s on both sides of t = " +
                  formatTimestamp(r.timestamp_s);
    } else {
      r.T_W_S = interpolatePose((it - 1)->T_W_S, it->T_W_S,
                                (r.timestamp_s - (it - 1)->timestamp_s) / (it->timestamp_s - (it - 1)->timestamp_s));
    }
    c.records.push_back(std::move(r));
  }
  if (c.records.empty()) fail(list, "lists no depth image");
  c.ground_truth = gt;
  c.description = "TUM RGB-D layout: depth factor 5000, poses interpolated in groundtruth.txt at each depth timestamp, "
                  "intrinsics from " + k_from;
  return c;
}

// ---- Replica (NICE-SLAM renders, as in nvblox's tests) --------------------------------------

FrameSourceContents importReplica(const fs::path& folder) {
  FrameSourceContents c;
  c.format = "replica";
  c.root = folder;
  SensorInfo& s = c.sensor;
  s.kind = SensorKind::Depth;
  fs::path cam = folder / "cam_params.json";
  if (!isFile(cam)) cam = folder.parent_path() / "cam_params.json";
  if (!isFile(cam)) fail(folder, "no cam_params.json here or in the parent folder (Replica layout)");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(readWholeFile(cam));
  } catch (const nlohmann::json::exception& e) {  // parse_error, or out_of_range for "1e1000"
    fail(cam, std::string("invalid JSON: ") + e.what());
  }
  if (!j.is_object() || !j.contains("camera") || !j["camera"].is_object()) fail(cam, "expected an object \"camera\"");
  const auto& jc = j["camera"];
  auto num = [&](const char* key) {
    if (!jc.contains(key) || !jc[key].is_number()) fail(cam, std::string("\"camera\" lacks the number \"") + key + "\"");
    return jc[key].get<double>();
  };
  // Image sides are checked as doubles before the conversion to int, which is undefined
  // behaviour for a value out of int's range (e.g. 1e300).
  auto side = [&](const char* key) {
    const double v = num(key);
    if (!(v >= 1.0 && v <= 1e6) || v != std::floor(v))
      fail(cam, std::string("\"camera\" \"") + key + "\" must be an integer in [1, 1000000]");
    return int(v);
  };
  s.intrinsics = CameraIntrinsics{side("w"), side("h"), num("fx"), num("fy"), num("cx"), num("cy")};
  const double scale = num("scale");
  if (!(scale > 0)) fail(cam, "\"scale\" must be > 0");
  s.depth_scale = 1.0 / scale;  // depth_m = value / scale
  try {
    s.intrinsics.validate();
  } catch (const std::invalid_argument& e) {
    fail(cam, e.what());
  }
  const fs::path traj = folder / "traj.txt";
  if (!isFile(traj)) fail(traj, "no such file");
  std::vector<long long> numbers;
  const std::vector<fs::path> depth_files = listMatching(folder / "results", std::regex("depth([0-9]+)\\.png"), &numbers);
  if (depth_files.empty()) fail(folder / "results", "no depthNNNNNN.png files (Replica layout)");
  // traj.txt: line k (0-based, non-empty lines) is the 4x4 row-major camera-to-world pose of frame k.
  std::map<long long, std::pair<std::size_t, std::vector<double>>> pose_lines;
  {
    const std::string text = readWholeFile(traj);
    LineReader lines(text);
    std::string_view line;
    std::vector<std::string_view> tok;
    long long k = 0;
    while (lines.next(line)) {
      splitWhitespace(line, tok);
      if (tok.empty()) continue;
      std::vector<double> m(16, 0.0);
      if (tok.size() != 16) {
        m.clear();  // reported per frame below, only if a frame uses this line
      } else {
        for (int i = 0; i < 16; ++i)
          if (!parseDouble(tok[std::size_t(i)], m[std::size_t(i)])) m[std::size_t(i)] = std::nan("");
      }
      pose_lines[k++] = {lines.lineNumber(), std::move(m)};
    }
  }
  for (std::size_t i = 0; i < depth_files.size(); ++i) {
    FrameRecord r;
    r.index = i;
    r.file = depth_files[i];
    r.timestamp_s = double(numbers[i]) / kNominalFrameRateHz;
    r.source = relTo(depth_files[i], folder);
    const auto it = pose_lines.find(numbers[i]);
    if (it == pose_lines.end()) {
      r.problem = "traj.txt has no line for frame " + std::to_string(numbers[i]);
    } else if (it->second.second.size() != 16) {
      r.problem = traj.string() + ":" + std::to_string(it->second.first) + ": expected 16 numbers (a row-major 4x4 pose)";
    } else {
      const std::string why = poseFromMatrix(it->second.second.data(), 4, r.T_W_S);
      if (!why.empty()) r.problem = traj.string() + ":" + std::to_string(it->second.first) + ": " + why;
    }
    c.records.push_back(std::move(r));
  }
  c.description = "Replica layout (NICE-SLAM renders): intrinsics and depth scale (1/scale) from " + cam.string() +
                  ", camera-to-world row-major 4x4 poses from traj.txt (line n for depth n), timestamp = frame number / 30 Hz";
  return c;
}

// ---- detection ------------------------------------------------------------------------------

namespace {

bool isLog(const fs::path& p) { return isFile(p / "sensor.json") && isFile(p / "frames.csv"); }
bool isReplicaScene(const fs::path& p) {
  return isFile(p / "traj.txt") && isDir(p / "results") && (isFile(p / "cam_params.json") || isFile(p.parent_path() / "cam_params.json"));
}
bool isSevenScenes(const fs::path& p) {
  return hasSevenScenesFrames(p) || (hasSevenScenesFrames(p / "depth") && isDir(p / "pose"));
}
bool isIclNuim(const fs::path& p) { return isFile(p / "pose.txt") && isDir(p / "depth"); }
bool isRedwood(const fs::path& p) {
  return isDir(p / "depth") && (isFile(p / "trajectory.log") || isFile(p / "odometry.log"));
}
bool isTum(const fs::path& p) { return isFile(p / "depth.txt") && isFile(p / "groundtruth.txt"); }

std::vector<fs::path> subfolders(const fs::path& p) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(p, ec))
    if (e.is_directory()) out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

DatasetFormat detectLayout(const fs::path& path, fs::path& folder) {
  folder = path;
  if (!isDir(path)) return DatasetFormat::Auto;
  if (isLog(path)) return DatasetFormat::Log;
  if (isReplicaScene(path)) return DatasetFormat::Replica;
  if (isSevenScenes(path)) {
    return isFile(path.parent_path() / "camera-intrinsics.txt") && !isFile(path / "camera-intrinsics.txt")
               ? DatasetFormat::ThreeDMatch
               : DatasetFormat::SevenScenes;
  }
  if (isTum(path)) return DatasetFormat::Tum;
  if (isRedwood(path)) return DatasetFormat::Redwood;
  if (isIclNuim(path)) return DatasetFormat::IclNuim;
  // One level down: a Replica root with one scene, a 3DMatch / 7-Scenes scene with one seq-XX,
  // Open3D's test data with RGBD/.
  std::vector<fs::path> replica, seqs, redwood;
  for (const fs::path& sub : subfolders(path)) {
    if (isReplicaScene(sub)) replica.push_back(sub);
    else if (hasSevenScenesFrames(sub)) seqs.push_back(sub);
    else if (isRedwood(sub)) redwood.push_back(sub);
  }
  auto pick = [&](const std::vector<fs::path>& found, DatasetFormat f, const char* what) {
    if (found.size() > 1) {
      std::string names;
      for (const fs::path& s : found) names += " " + s.filename().string();
      throw FileError(path.string() + ": holds several " + what + " (" + names.substr(1) + "); open one of them");
    }
    folder = found.front();
    return f;
  };
  if (!replica.empty()) return pick(replica, DatasetFormat::Replica, "Replica scenes");
  if (!seqs.empty())
    return pick(seqs, isFile(path / "camera-intrinsics.txt") ? DatasetFormat::ThreeDMatch : DatasetFormat::SevenScenes,
                "sequences");
  if (!redwood.empty()) return pick(redwood, DatasetFormat::Redwood, "Redwood sequences");
  return DatasetFormat::Auto;
}

}  // namespace vdbmap::io::detail
