// ROS1 bags through rosbag_storage (see ros_bag.hpp). Compiled without bag support when the
// packages are missing: every entry point then says how to get it.
#include "vdbmap/io/ros_bag.hpp"

#include "vdbmap/io/errors.hpp"
#include "vdbmap/io/pose_interpolation.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

#ifdef VDBMAP_HAS_ROSBAG
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#endif

namespace vdbmap::io {

void RosBagConfig::validate() const {
  if (!isValidRigidTransform(T_B_S)) throw std::invalid_argument("RosBagConfig.T_B_S must be a rigid transform");
  if (!(min_range_m >= 0.0 && min_range_m < max_range_m && max_range_m <= 1000.0))
    throw std::invalid_argument("RosBagConfig: ranges must satisfy 0 <= min_range_m < max_range_m <= 1000");
}

#ifndef VDBMAP_HAS_ROSBAG

bool rosBagSupport() { return false; }
namespace {
[[noreturn]] void unsupported(const std::filesystem::path& bag) {
  throw FileError(bag.string() + ": this build reads no ROS bags (install librosbag-storage-dev, libsensor-msgs-dev, "
                                 "libnav-msgs-dev and libgeometry-msgs-dev, then rebuild)");
}
}  // namespace
RosBagInfo inspectRosBag(const std::filesystem::path& bag) { unsupported(bag); }
std::unique_ptr<FrameSource> openRosBag(const std::filesystem::path& bag, const RosBagConfig&) { unsupported(bag); }

#else

bool rosBagSupport() { return true; }

namespace {

constexpr const char* kImage = "sensor_msgs/Image";
constexpr const char* kCameraInfo = "sensor_msgs/CameraInfo";
constexpr const char* kOdometry = "nav_msgs/Odometry";
constexpr const char* kPoseStamped = "geometry_msgs/PoseStamped";
constexpr const char* kTransformStamped = "geometry_msgs/TransformStamped";
constexpr const char* kPath = "nav_msgs/Path";

std::string stampText(double t) { return formatTimestamp(t); }

[[noreturn]] void fail(const std::filesystem::path& bag, const std::string& what) { throw FileError(bag.string() + ": " + what); }

/// Topic -> type of every connection.
std::map<std::string, std::string> topicTypes(const rosbag::Bag& bag) {
  std::map<std::string, std::string> types;
  rosbag::View view(bag);
  for (const rosbag::ConnectionInfo* c : view.getConnections()) types[c->topic] = c->datatype;
  return types;
}

std::string listTopics(const std::map<std::string, std::string>& types) {
  std::string out;
  for (const auto& [topic, type] : types) out += (out.empty() ? "" : ", ") + topic + " (" + type + ")";
  return out.empty() ? "none" : out;
}

/// The topic to read: `given` (checked to exist with one of `accepted` types), or the bag's only
/// topic of those types. Empty when `optional` and there is none.
std::string chooseTopic(const std::filesystem::path& bag, const std::map<std::string, std::string>& types,
                        const std::string& given, const std::vector<std::string>& accepted, const char* option,
                        bool optional = false) {
  const auto acceptedType = [&](const std::string& t) { return std::find(accepted.begin(), accepted.end(), t) != accepted.end(); };
  std::string kinds;
  for (const std::string& a : accepted) kinds += (kinds.empty() ? "" : " or ") + a;
  if (!given.empty()) {
    const auto it = types.find(given);
    if (it == types.end()) fail(bag, "no topic " + given + " (" + option + "); the bag has " + listTopics(types));
    if (!acceptedType(it->second)) fail(bag, "topic " + given + " is " + it->second + ", " + option + " needs " + kinds);
    return given;
  }
  std::vector<std::string> found;
  for (const auto& [topic, type] : types)
    if (acceptedType(type)) found.push_back(topic);
  if (found.size() == 1) return found.front();
  if (found.empty() && optional) return {};
  if (found.empty()) fail(bag, "no " + kinds + " topic; the bag has " + listTopics(types));
  std::string names;
  for (const std::string& f : found) names += (names.empty() ? "" : ", ") + f;
  fail(bag, std::string("several ") + kinds + " topics (" + names + "): choose one with " + option);
}

Pose3d toPose(const geometry_msgs::Point& p, const geometry_msgs::Quaternion& q, const std::filesystem::path& bag,
              const std::string& topic, double t) {
  const Eigen::Quaterniond quat(q.w, q.x, q.y, q.z);
  const Vec3d position(p.x, p.y, p.z);
  if (!position.allFinite() || !quat.coeffs().allFinite() || std::abs(quat.norm() - 1.0) > kQuaternionNormTolerance)
    fail(bag, "topic " + topic + " at " + stampText(t) + ": not a valid pose (non-finite, or quaternion norm " +
                  std::to_string(quat.norm()) + ")");
  return poseFromTranslationQuaternion(position, q.x, q.y, q.z, q.w);  // as logs' poses are made
}

// ROS's deserializer resizes a vector to the length a message declares before checking that the
// message holds it (fuzz_bag: a 39 KB bag whose image declares 4 GiB of pixels allocated them).
// So each message's serialized bytes are walked first for the six types read here: every string
// and vector length must fit in what is left of the message. Layouts: the messages' .msg files.
class MessageWalk {
 public:
  explicit MessageWalk(const std::vector<std::uint8_t>& bytes) : p_(bytes.data()), left_(bytes.size()) {}
  bool ok() const { return ok_; }
  void skip(std::size_t n) {
    if (!ok_ || n > left_) {
      ok_ = false;
      return;
    }
    p_ += n;
    left_ -= n;
  }
  std::uint32_t u32() {
    std::uint32_t v = 0;
    if (ok_ && left_ >= 4) std::memcpy(&v, p_, 4);
    skip(4);
    return v;
  }
  void string() { skip(u32()); }
  void vector(std::size_t element_bytes) {
    const std::uint64_t n = u32();
    if (ok_ && n > left_ / element_bytes) ok_ = false;
    skip(std::size_t(n) * element_bytes);
  }
  void header() {  // seq, stamp (sec, nsec), frame_id
    skip(12);
    string();
  }
  void poseStamped() {
    header();
    skip(7 * 8);
  }

 private:
  const std::uint8_t* p_;
  std::size_t left_;
  bool ok_ = true;
};

void walk(MessageWalk& w, const sensor_msgs::Image*) {
  w.header();
  w.skip(4 + 4);   // height, width
  w.string();      // encoding
  w.skip(1 + 4);   // is_bigendian, step
  w.vector(1);     // data
}
void walk(MessageWalk& w, const sensor_msgs::CameraInfo*) {
  w.header();
  w.skip(4 + 4);   // height, width
  w.string();      // distortion_model
  w.vector(8);     // D
  w.skip((9 + 9 + 12) * 8 + 4 + 4 + 17);  // K, R, P, binning_x, binning_y, roi
}
void walk(MessageWalk& w, const geometry_msgs::PoseStamped*) { w.poseStamped(); }
void walk(MessageWalk& w, const geometry_msgs::TransformStamped*) {
  w.header();
  w.string();      // child_frame_id
  w.skip(7 * 8);   // translation, rotation
}
void walk(MessageWalk& w, const nav_msgs::Odometry*) {
  w.header();
  w.string();                       // child_frame_id
  w.skip((7 + 36 + 6 + 36) * 8);    // pose with covariance, twist with covariance
}
void walk(MessageWalk& w, const nav_msgs::Path*) {
  w.header();
  const std::uint32_t n = w.u32();
  for (std::uint32_t k = 0; k < n && w.ok(); ++k) w.poseStamped();  // each at least 72 bytes: bounded
}

/// m.instantiate<T>() once the message's lengths are known to fit in it. FileError when they do
/// not, and when rosbag returns no message: it does so for a message whose connection names
/// another type or MD5 than T's (fuzz_bag: a topic whose connections disagree on its type).
template <class T>
boost::shared_ptr<T> instantiateChecked(const rosbag::MessageInstance& m, const std::filesystem::path& bag) {
  std::vector<std::uint8_t> bytes(m.size());  // bounded by its chunk (checkBagStructure)
  ros::serialization::OStream out(bytes.data(), std::uint32_t(bytes.size()));
  m.write(out);
  MessageWalk w(bytes);
  walk(w, static_cast<const T*>(nullptr));
  // Topic, type and MD5 are the bag's text: control bytes escaped (errors.hpp).
  const std::string where = "topic " + escapeControl(m.getTopic()) + " at " + stampText(m.getTime().toSec()) + ": ";
  if (!w.ok())
    fail(bag, where + "a " + escapeControl(m.getDataType()) + " message declares more data than its " +
                  std::to_string(bytes.size()) + " bytes hold");
  boost::shared_ptr<T> message = m.instantiate<T>();
  if (!message)
    fail(bag, where + "a message of type " + escapeControl(m.getDataType()) + " (MD5 " + escapeControl(m.getMD5Sum()) +
                  ") where " + ros::message_traits::datatype<T>() + " (MD5 " + ros::message_traits::md5sum<T>() +
                  ") was expected");
  return message;
}

/// Every message of `topic` in bag order.
std::vector<rosbag::MessageInstance> messages(const rosbag::Bag& bag, const std::string& topic) {
  std::vector<rosbag::MessageInstance> out;
  rosbag::View view(bag, rosbag::TopicQuery(topic));
  for (const rosbag::MessageInstance& m : view) out.push_back(m);
  return out;
}

/// The body poses of the pose topic, by header stamp.
std::vector<StampedPose> readPoses(const std::filesystem::path& bag_path, const rosbag::Bag& bag, const std::string& topic,
                                   const std::string& type) {
  std::vector<StampedPose> poses;
  for (const rosbag::MessageInstance& m : messages(bag, topic)) {
    double t = 0.0;
    Pose3d T;
    if (type == kOdometry) {
      const auto msg = instantiateChecked<nav_msgs::Odometry>(m, bag_path);
      t = msg->header.stamp.toSec();
      T = toPose(msg->pose.pose.position, msg->pose.pose.orientation, bag_path, topic, t);
    } else if (type == kPoseStamped) {
      const auto msg = instantiateChecked<geometry_msgs::PoseStamped>(m, bag_path);
      t = msg->header.stamp.toSec();
      T = toPose(msg->pose.position, msg->pose.orientation, bag_path, topic, t);
    } else {
      const auto msg = instantiateChecked<geometry_msgs::TransformStamped>(m, bag_path);
      t = msg->header.stamp.toSec();
      geometry_msgs::Point p;
      p.x = msg->transform.translation.x;
      p.y = msg->transform.translation.y;
      p.z = msg->transform.translation.z;
      T = toPose(p, msg->transform.rotation, bag_path, topic, t);
    }
    if (!poses.empty() && !(t > poses.back().timestamp_s))
      fail(bag_path, "topic " + topic + ": stamp " + stampText(t) + " is not after the previous pose's " +
                         stampText(poses.back().timestamp_s) + " (stamps must increase)");
    poses.push_back({t, T});
  }
  if (poses.empty()) fail(bag_path, "topic " + topic + " holds no pose");
  return poses;
}

CameraIntrinsics readCamera(const std::filesystem::path& bag_path, const rosbag::Bag& bag, const std::string& topic) {
  const std::vector<rosbag::MessageInstance> all = messages(bag, topic);
  if (all.empty()) fail(bag_path, "topic " + topic + " holds no CameraInfo message");
  const auto info = instantiateChecked<sensor_msgs::CameraInfo>(all.front(), bag_path);
  const std::string model = info->distortion_model;
  const bool zero = std::all_of(info->D.begin(), info->D.end(), [](double d) { return d == 0.0; });
  if (!(model.empty() || model == "none" ||
        ((model == "plumb_bob" || model == "rational_polynomial" || model == "equidistant") && zero)))
    fail(bag_path, "topic " + topic + ": distortion model '" + model +
                       "' with non-zero coefficients; rectified depth images are needed (distortion none, or all "
                       "coefficients zero)");
  CameraIntrinsics K;
  K.width = int(info->width);
  K.height = int(info->height);
  K.fx = info->K[0];
  K.fy = info->K[4];
  K.cx = info->K[2];
  K.cy = info->K[5];
  try {
    K.validate();
  } catch (const std::invalid_argument& e) {
    fail(bag_path, "topic " + topic + ": " + e.what());
  }
  return K;
}

DepthImage decodeDepth(const sensor_msgs::Image& img, const CameraIntrinsics& K, const std::filesystem::path& bag,
                       const std::string& topic) {
  const double t = img.header.stamp.toSec();
  const auto where = [&] { return "topic " + topic + " at " + stampText(t) + ": "; };
  if (int(img.width) != K.width || int(img.height) != K.height)
    fail(bag, where() + "image is " + std::to_string(img.width) + "x" + std::to_string(img.height) + ", the camera " +
                  std::to_string(K.width) + "x" + std::to_string(K.height));
  const bool u16 = img.encoding == "16UC1" || img.encoding == "mono16";
  const bool f32 = img.encoding == "32FC1";
  if (!u16 && !f32) fail(bag, where() + "encoding '" + img.encoding + "' (16UC1 millimetres or 32FC1 metres are read)");
  const std::size_t px = u16 ? 2 : 4;
  if (img.step < img.width * px || img.data.size() < std::size_t(img.step) * img.height)
    fail(bag, where() + "step " + std::to_string(img.step) + " and " + std::to_string(img.data.size()) +
                  " bytes do not hold the image");
  const bool swap = img.is_bigendian != 0;
  const auto pixel = [&](int u, int v, std::uint8_t* b) {
    std::memcpy(b, img.data.data() + std::size_t(v) * img.step + std::size_t(u) * px, px);
    if (swap) std::reverse(b, b + px);
  };
  if (u16) {  // millimetres, converted as 16-bit PNGs are (depthFromRaw), so both give the same image
    std::vector<std::uint16_t> raw(std::size_t(K.width) * K.height);
    for (int v = 0; v < K.height; ++v)
      for (int u = 0; u < K.width; ++u) {
        std::uint8_t b[2];
        pixel(u, v, b);
        std::memcpy(&raw[std::size_t(v) * K.width + u], b, 2);
      }
    return depthFromRaw(K.width, K.height, raw.data(), 0.001);
  }
  DepthImage d(K.width, K.height);
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      std::uint8_t b[4];
      pixel(u, v, b);
      float m;
      std::memcpy(&m, b, 4);
      d.at(u, v) = std::isfinite(m) && m > 0.0f ? m : 0.0f;
    }
  return d;
}

class RosBagSource final : public FrameSource {
 public:
  /// The camera is the one in contents.sensor (CameraInfo's).
  RosBagSource(FrameSourceContents contents, std::unique_ptr<rosbag::Bag> bag, std::vector<rosbag::MessageInstance> depth,
               std::string topic)
      : FrameSource(std::move(contents)), bag_(std::move(bag)), depth_(std::move(depth)), topic_(std::move(topic)) {}

  Frame load(std::size_t i) const override {
    const FrameRecord& r = record(i);  // std::out_of_range past the end
    Frame f;
    f.index = i;
    f.timestamp_s = r.timestamp_s;
    f.T_W_S = r.T_W_S;
    const std::lock_guard<std::mutex> lock(mutex_);  // rosbag's reader is not thread-safe
    try {
      const auto img = instantiateChecked<sensor_msgs::Image>(depth_[i], root());
      f.data = SensorFrame::depth(decodeDepth(*img, *sharedIntrinsics(), root(), topic_), sharedIntrinsics());
    } catch (const FileError& e) {
      throw BadFrameError(i, e.what());
    } catch (const std::exception& e) {
      throw BadFrameError(i, root().string() + ": topic " + topic_ + " at " + stampText(r.timestamp_s) + ": " + e.what());
    }
    return f;
  }

 private:
  std::unique_ptr<rosbag::Bag> bag_;
  std::vector<rosbag::MessageInstance> depth_;
  std::string topic_;
  mutable std::mutex mutex_;
};

// rosbag_storage trusts the lengths a bag holds: it allocates a record's header or data length,
// and a chunk's uncompressed size, before checking them against the file (fuzz_bag: a 35 KB bag
// whose connection record declares a 0xffffffff-byte header made it allocate 4 GiB). So the
// record structure is walked first, reading record headers only (a bag may be gigabytes): every
// length must fit in the file, the positions the index names (index_pos, chunk_pos) must be the
// starts of records of the right kind, the counted records (chunk infos, index data) must hold
// exactly their count, and a chunk may not claim more than kMaxBagChunkBytes uncompressed.
// Format: http://wiki.ros.org/Bags/Format/2.0 (records: header_len, header, data_len, data).
constexpr std::uint64_t kMaxBagChunkBytes = std::uint64_t{256} << 20;  // rosbag writes 768 KiB chunks
constexpr std::uint32_t kMaxBagHeaderBytes = std::uint32_t{16} << 20;  // message definitions are KBs

void checkBagStructure(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open the bag");
  std::error_code ec;
  const std::uint64_t file_size = std::filesystem::file_size(path, ec);
  if (ec) fail(path, "cannot determine the bag's size");
  const std::string kMagic = "#ROSBAG V2.0\n";
  std::string magic(kMagic.size(), '\0');
  if (!in.read(magic.data(), std::streamsize(magic.size())) || magic != kMagic)
    fail(path, "not a ROS bag of format 2.0 (its first line must be '#ROSBAG V2.0')");
  const auto u32 = [](const char* p) {
    std::uint32_t v;
    std::memcpy(&v, p, 4);  // bags are little endian, as the hosts we build for
    return v;
  };
  std::map<std::uint64_t, std::uint8_t> op_at;  // record start -> op
  std::vector<std::uint64_t> index_positions, chunk_positions;
  std::uint64_t pos = kMagic.size();
  std::string header;
  // A header (of a record, of a record inside a chunk, or a connection record's data): fields of
  // a uint32 length, then "name=value". ros::Header::parse checks a length against 1e6 only, not
  // against the header (fuzz_bag: heap-buffer-overflow), so every one is checked here.
  const auto headerFields = [&](const std::string& bytes, const std::string& at) {
    std::map<std::string, std::string> fields;
    for (std::size_t f = 0; f < bytes.size();) {
      if (bytes.size() - f < 4) fail(path, "corrupt bag: a header field length is cut off" + at);
      const std::uint32_t field_len = u32(bytes.data() + f);
      f += 4;
      if (field_len > bytes.size() - f) fail(path, "corrupt bag: a header field runs past its header" + at);
      const std::string field = bytes.substr(f, field_len);
      f += field_len;
      const std::size_t eq = field.find('=');
      if (eq == std::string::npos) fail(path, "corrupt bag: a header field has no '='" + at);
      fields[field.substr(0, eq)] = field.substr(eq + 1);
    }
    return fields;
  };
  // Reads `n` bytes at `at_byte` (n already checked against the file).
  const auto readAt = [&](std::uint64_t at_byte, std::uint64_t n, const std::string& at) {
    std::string bytes(n, '\0');
    in.seekg(std::streamoff(at_byte));
    if (!in.read(bytes.data(), std::streamsize(n))) fail(path, "cannot read the bag" + at);
    return bytes;
  };
  // The last chunk: index records after it point into it.
  bool have_chunk = false, chunk_plain = false;
  std::uint32_t chunk_size = 0;
  std::set<std::uint32_t> chunk_records;
  while (pos < file_size) {
    const std::string at = " (record at byte " + std::to_string(pos) + ")";
    char len[4];
    if (file_size - pos < 4 || !in.read(len, 4)) fail(path, "truncated bag: a record header length runs past the end" + at);
    const std::uint32_t header_len = u32(len);
    if (header_len > kMaxBagHeaderBytes || header_len > file_size - pos - 4)
      fail(path, "corrupt bag: record header length " + std::to_string(header_len) + " runs past the end of the file" + at);
    header.resize(header_len);
    if (!in.read(header.data(), std::streamsize(header_len))) fail(path, "cannot read the bag" + at);
    const std::map<std::string, std::string> fields = headerFields(header, at);
    const std::uint64_t data_len_pos = pos + 4 + header_len;
    if (file_size - data_len_pos < 4 || !in.read(len, 4)) fail(path, "truncated bag: a record data length runs past the end" + at);
    const std::uint32_t data_len = u32(len);
    if (data_len > file_size - data_len_pos - 4)
      fail(path, "corrupt bag: record data length " + std::to_string(data_len) + " runs past the end of the file" + at);
    const auto field = [&](const char* name, std::size_t size) -> const std::string& {
      const auto it = fields.find(name);
      if (it == fields.end() || it->second.size() != size)
        fail(path, std::string("corrupt bag: header field '") + name + "' is missing or not " + std::to_string(size) + " bytes" + at);
      return it->second;
    };
    const std::uint8_t op = std::uint8_t(field("op", 1)[0]);
    op_at[pos] = op;
    if (op == 0x03) {  // file header: where the index starts
      std::uint64_t index_pos;
      std::memcpy(&index_pos, field("index_pos", 8).data(), 8);
      index_positions.push_back(index_pos);
    } else if (op == 0x05) {  // chunk: uncompressed size is allocated when it is read
      const std::uint32_t size = u32(field("size", 4).data());
      if (size > kMaxBagChunkBytes)
        fail(path, "chunk of " + std::to_string(size) + " bytes uncompressed, more than the " +
                       std::to_string(kMaxBagChunkBytes) + " bytes read" + at);
      // Its records, where the index records after it point (rosbag_storage reads a record header
      // at each offset without checking it against the chunk: fuzz_bag, SEGV). An uncompressed
      // chunk is walked like the file; a compressed one's offsets are only checked against its size.
      chunk_size = size;
      const auto compression = fields.find("compression");
      chunk_plain = compression != fields.end() && compression->second == "none";
      chunk_records.clear();
      have_chunk = true;
      if (chunk_plain) {
        if (size != data_len) fail(path, "corrupt bag: an uncompressed chunk's size differs from its data" + at);
        for (std::uint64_t o = 0; o < data_len;) {
          char lengths[4];
          in.seekg(std::streamoff(data_len_pos + 4 + o));
          if (data_len - o < 8 || !in.read(lengths, 4)) fail(path, "corrupt bag: a record in a chunk is cut off" + at);
          const std::uint64_t inner_header = u32(lengths);
          if (inner_header > data_len - o - 8) fail(path, "corrupt bag: a record in a chunk runs past it" + at);
          headerFields(readAt(data_len_pos + 4 + o + 4, inner_header, at), at);
          in.seekg(std::streamoff(data_len_pos + 4 + o + 4 + inner_header));
          if (!in.read(lengths, 4)) fail(path, "cannot read the bag" + at);
          const std::uint64_t inner_data = u32(lengths);
          if (inner_data > data_len - o - 8 - inner_header) fail(path, "corrupt bag: a record in a chunk runs past it" + at);
          chunk_records.insert(std::uint32_t(o));
          o += 8 + inner_header + inner_data;
        }
      }
    } else if (op == 0x06) {  // chunk info: where its chunk is, and count (connection, count) pairs
      std::uint64_t chunk_pos;
      std::memcpy(&chunk_pos, field("chunk_pos", 8).data(), 8);
      chunk_positions.push_back(chunk_pos);
      if (std::uint64_t(u32(field("count", 4).data())) * 8 != data_len)
        fail(path, "corrupt bag: a chunk info's count does not match its data" + at);
    } else if (op == 0x07) {  // connection: its data is a header too (topic, type, md5sum, ...)
      if (data_len > kMaxBagHeaderBytes) fail(path, "corrupt bag: a connection of " + std::to_string(data_len) + " bytes" + at);
      headerFields(readAt(data_len_pos + 4, data_len, at), at);
    } else if (op == 0x04) {  // index data: count (time, offset) pairs into the chunk before it
      if (std::uint64_t(u32(field("count", 4).data())) * 12 != data_len)
        fail(path, "corrupt bag: an index record's count does not match its data" + at);
      if (!have_chunk) fail(path, "corrupt bag: an index record before any chunk" + at);
      const std::string entries = readAt(data_len_pos + 4, data_len, at);
      for (std::size_t k = 0; k + 12 <= entries.size(); k += 12) {
        const std::uint32_t offset = u32(entries.data() + k + 8);
        const bool ok = chunk_plain ? chunk_records.count(offset) != 0 : std::uint64_t(offset) + 8 <= chunk_size;
        if (!ok)
          fail(path, "corrupt bag: an index entry points to byte " + std::to_string(offset) +
                         " of its chunk, where no message record starts" + at);
      }
    }
    pos = data_len_pos + 4 + data_len;
    in.seekg(std::streamoff(pos));
  }
  for (const std::uint64_t p : index_positions)
    if (p != 0 && op_at.count(p) == 0) fail(path, "corrupt bag: index_pos " + std::to_string(p) + " is not the start of a record");
  for (const std::uint64_t p : chunk_positions) {
    const auto it = op_at.find(p);
    if (it == op_at.end() || it->second != 0x05) fail(path, "corrupt bag: chunk_pos " + std::to_string(p) + " is not the start of a chunk");
  }
}

std::unique_ptr<rosbag::Bag> openBag(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw FileError(path.string() + ": no such bag file");
  checkBagStructure(path);
  auto bag = std::make_unique<rosbag::Bag>();
  bag->open(path.string(), rosbag::bagmode::Read);
  return bag;
}

}  // namespace

RosBagInfo inspectRosBag(const std::filesystem::path& path) {
  try {
    const std::unique_ptr<rosbag::Bag> bag = openBag(path);
    RosBagInfo info;
    rosbag::View all(*bag);
    info.messages = all.size();
    if (info.messages > 0) {
      info.start_s = all.getBeginTime().toSec();
      info.end_s = all.getEndTime().toSec();
    }
    for (const auto& [topic, type] : topicTypes(*bag)) {
      rosbag::View view(*bag, rosbag::TopicQuery(topic));
      RosBagTopic t{topic, type, view.size(), 0.0, 0.0};
      if (t.messages > 0) {
        t.first_s = view.getBeginTime().toSec();
        t.last_s = view.getEndTime().toSec();
      }
      info.topics.push_back(t);
    }
    return info;
  } catch (const FileError&) {
    throw;
  } catch (const std::exception& e) {
    throw FileError(path.string() + ": cannot read the bag (" + e.what() + ")");
  }
}

std::unique_ptr<FrameSource> openRosBag(const std::filesystem::path& path, const RosBagConfig& options) {
  options.validate();
  try {
    std::unique_ptr<rosbag::Bag> bag = openBag(path);
    const std::map<std::string, std::string> types = topicTypes(*bag);
    const std::string depth_topic = chooseTopic(path, types, options.depth_topic, {kImage}, "--depth-topic");
    const std::string info_topic = chooseTopic(path, types, options.camera_info_topic, {kCameraInfo}, "--camera-info-topic");
    const std::string pose_topic =
        chooseTopic(path, types, options.pose_topic, {kOdometry, kPoseStamped, kTransformStamped}, "--pose-topic");
    const std::string corrections_topic =
        options.corrections_topic == "-" ? std::string()
                                         : chooseTopic(path, types, options.corrections_topic, {kPath}, "--corrections-topic", true);

    const CameraIntrinsics K = readCamera(path, *bag, info_topic);
    const std::vector<StampedPose> body = readPoses(path, *bag, pose_topic, types.at(pose_topic));

    FrameSourceContents c;
    c.format = "rosbag";
    c.root = path;
    c.sensor.kind = SensorKind::Depth;
    c.sensor.intrinsics = K;
    c.sensor.depth_scale = 0.001;
    c.sensor.min_range_m = options.min_range_m;
    c.sensor.max_range_m = options.max_range_m;
    std::vector<rosbag::MessageInstance> depth;
    std::size_t outside = 0;
    std::string encoding;
    for (const rosbag::MessageInstance& m : messages(*bag, depth_topic)) {
      const auto img = instantiateChecked<sensor_msgs::Image>(m, path);
      const double t = img->header.stamp.toSec();
      if (encoding.empty()) encoding = img->encoding;
      if (img->encoding != "16UC1" && img->encoding != "mono16" && img->encoding != "32FC1")
        fail(path, "topic " + depth_topic + " at " + stampText(t) + ": encoding '" + img->encoding +
                       "' (16UC1 millimetres or 32FC1 metres are read)");
      if (!c.records.empty() && !(t > c.records.back().timestamp_s))
        fail(path, "topic " + depth_topic + ": stamp " + stampText(t) + " is not after the previous image's " +
                       stampText(c.records.back().timestamp_s) + " (stamps must increase)");
      const std::optional<Pose3d> T_W_B = poseAt(body, t);
      if (!T_W_B) {
        ++outside;
        continue;
      }
      FrameRecord r;
      r.index = c.records.size();
      r.timestamp_s = t;
      r.file = path;
      r.T_W_S = *T_W_B * options.T_B_S;
      r.source = depth_topic + "@" + stampText(t);
      c.records.push_back(std::move(r));
      depth.push_back(m);
    }
    if (c.records.empty())
      fail(path, "no image of " + depth_topic + " lies within the pose stream's span (" + pose_topic + ", " +
                     stampText(body.front().timestamp_s) + " to " + stampText(body.back().timestamp_s) + ")");

    // Corrections: each Path message an event after the last frame at or before its stamp.
    std::size_t events_skipped = 0, poses_left_out = 0;
    if (!corrections_topic.empty()) {
      for (const rosbag::MessageInstance& m : messages(*bag, corrections_topic)) {
        const auto path_msg = instantiateChecked<nav_msgs::Path>(m, path);
        const double t_event = path_msg->header.stamp.isZero() ? m.getTime().toSec() : path_msg->header.stamp.toSec();
        const auto after = std::upper_bound(c.records.begin(), c.records.end(), t_event,
                                            [](double t, const FrameRecord& r) { return t < r.timestamp_s; });
        if (after == c.records.begin()) {
          ++events_skipped;
          continue;
        }
        CorrectionEvent ev;
        ev.event_frame = std::size_t(after - c.records.begin()) - 1;
        ev.event_timestamp_s = c.records[ev.event_frame].timestamp_s;
        ev.file = path;
        std::vector<StampedPose> poses;
        for (const geometry_msgs::PoseStamped& p : path_msg->poses) {
          double t = p.header.stamp.toSec();
          if (const auto near = findStamp(c.records.begin(), c.records.end(), t); near != c.records.end())
            t = near->timestamp_s;
          if (t < c.records.front().timestamp_s || t > ev.event_timestamp_s) {
            ++poses_left_out;
            continue;
          }
          poses.push_back({t, toPose(p.pose.position, p.pose.orientation, path, corrections_topic, t) * options.T_B_S});
        }
        std::sort(poses.begin(), poses.end(), [](const StampedPose& a, const StampedPose& b) { return a.timestamp_s < b.timestamp_s; });
        for (const StampedPose& p : poses)
          if (ev.poses.empty() || p.timestamp_s > ev.poses.back().timestamp_s) ev.poses.push_back(p);
        if (ev.poses.empty()) {
          ++events_skipped;
          continue;
        }
        c.corrections.push_back(std::move(ev));
      }
    }
    std::ostringstream d;
    d << "ROS bag: depth " << depth_topic << " (" << encoding << "), intrinsics from " << info_topic << ", body poses "
      << pose_topic << " (" << types.at(pose_topic) << ") interpolated at the depth stamps";
    if (!options.T_B_S.isApprox(Pose3d::Identity())) d << " times the extrinsic T_B_S";
    d << "; " << outside << " images outside the pose stream skipped";
    if (!corrections_topic.empty())
      d << "; corrections from " << corrections_topic << ": " << c.corrections.size() << " events (" << events_skipped
        << " before the first frame or empty skipped, " << poses_left_out << " poses outside the frames left out)";
    c.description = d.str();
    return std::make_unique<RosBagSource>(std::move(c), std::move(bag), std::move(depth), depth_topic);
  } catch (const FileError&) {
    throw;
  } catch (const std::exception& e) {
    throw FileError(path.string() + ": cannot read the bag (" + e.what() + ")");
  }
}

#endif  // VDBMAP_HAS_ROSBAG

}  // namespace vdbmap::io
