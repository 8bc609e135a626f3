// The keyframe store's file (docs/formats.md, "MAP.keyframes"): a little-endian binary file.
//   header:   "VDBMAPKF", u32 version (3), u32 unit id bytes (0 in version 1), u64 keyframe count,
//             the unit id (ASCII, the save's AtomicFileSet::unitId(); since version 2)
//   each:     u64 id, f64 timestamp, f64[16] T_W_S_integrated, f64[16] T_W_S_latest (column-major),
//             u8 integrated, u8 kind (0 depth, 1 points), u8 compressed, u8 has camera,
//             i32 stride, u32 count, f64 unit_m,
//             [camera: i32 width, i32 height, f64 fx, fy, cx, cy],
//             u64 payload bytes, the payload as stored (zlib or raw codes),
//             u32 CRC-32 of the record's bytes from its id to its payload's end (since version 3)
#include "vdbmap/keyframe_store.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/file_error.hpp"

#include <libdeflate.h>

#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

namespace vdbmap {
namespace {

constexpr char kMagic[8] = {'V', 'D', 'B', 'M', 'A', 'P', 'K', 'F'};
/// 2: the header holds the unit id of the save (the map's), checked by Mapper::load.
/// 3: each record ends with its CRC-32, so that a damaged stride, unit or payload cannot load as a
/// frame the map never integrated.
constexpr std::uint32_t kVersion = 3;
constexpr std::uint32_t kFirstChecksummedVersion = 3;
/// Deflate expands its input at most 1032-fold: a payload of n compressed bytes that claims more
/// codes than that is refused before anything is allocated for them.
constexpr std::uint64_t kMaxInflateRatio = 1032;
constexpr std::uint32_t kMaxUnitIdBytes = 64;
/// The smallest keyframe record (no camera, empty payload): what bounds a count read from a file.
constexpr std::uint64_t kMinRecordBytes = 8 + 8 + 2 * 16 * 8 + 4 + 4 + 4 + 8 + 8;

bool littleEndian() {
  const std::uint16_t one = 1;
  std::uint8_t first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

template <typename T>
void put(std::ostream& os, const T& v) {
  os.write(reinterpret_cast<const char*>(&v), sizeof(T));
}

void putPose(std::ostream& os, const Pose3d& T) {
  const Eigen::Matrix4d m = T.matrix();
  os.write(reinterpret_cast<const char*>(m.data()), 16 * sizeof(double));
}

/// Reads from a file with a known size, naming the file and the record in every error.
class Reader {
 public:
  explicit Reader(const std::filesystem::path& path) : path_(path), in_(path, std::ios::binary) {
    std::error_code ec;
    if (!in_) throw FileError("cannot open keyframe store " + path.string());
    size_ = std::filesystem::file_size(path, ec);
    if (ec) throw FileError("cannot read keyframe store " + path.string() + ": " + ec.message());
  }
  template <typename T>
  T get(const char* field) {
    T v{};
    bytes(&v, sizeof(T), field);
    return v;
  }
  void bytes(void* out, std::uint64_t n, const char* field) {
    if (n > left()) fail(std::string("the file ends inside ") + field);
    in_.read(static_cast<char*>(out), std::streamsize(n));
    if (!in_) fail(std::string("cannot read ") + field);
    pos_ += n;
    crc_ = std::uint32_t(libdeflate_crc32(crc_, out, std::size_t(n)));
  }
  /// Starts the CRC-32 of the bytes read from here on.
  void startChecksum() { crc_ = 0; }
  /// The CRC-32 of the bytes read since startChecksum().
  std::uint32_t checksum() const { return crc_; }
  Pose3d pose(const char* field) {
    Eigen::Matrix4d m;
    bytes(m.data(), 16 * sizeof(double), field);
    const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
    if (!m.allFinite() || (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 ||
        R.determinant() < 0.0 || (m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 0.0)
      fail(std::string(field) + " is not a rigid transform");
    Pose3d T;
    T.matrix() = m;
    return T;
  }
  std::uint64_t left() const { return size_ - pos_; }
  [[noreturn]] void fail(const std::string& what) const {
    throw FileError(path_.string() + (record_.empty() ? "" : ": " + record_) + ": " + what);
  }
  void setRecord(std::string record) { record_ = std::move(record); }

 private:
  std::filesystem::path path_;
  std::ifstream in_;
  std::uint64_t size_ = 0, pos_ = 0;
  std::uint32_t crc_ = 0;
  std::string record_;
};

/// Bytes of codes per pixel (a 16-bit row delta) or per point (three 32-bit coordinates).
std::uint64_t codeBytes(bool depth) { return depth ? 2 : 12; }

}  // namespace

/// Reads and writes EncodedFrame's private fields (its friend).
struct KeyframeStoreFile {
  static void write(std::ostream& os, const EncodedFrame& f) {
    put(os, std::uint8_t(f.kind_ == EncodedFrame::Kind::Depth ? 0 : 1));
    put(os, std::uint8_t(f.compressed_ ? 1 : 0));
    put(os, std::uint8_t(f.intrinsics_ ? 1 : 0));
    put(os, std::int32_t(f.stride_));
    put(os, f.count_);
    put(os, f.unit_m_);
    if (f.intrinsics_) {
      put(os, std::int32_t(f.intrinsics_->width));
      put(os, std::int32_t(f.intrinsics_->height));
      for (double v : {f.intrinsics_->fx, f.intrinsics_->fy, f.intrinsics_->cx, f.intrinsics_->cy}) put(os, v);
    }
    put(os, std::uint64_t(f.payload_.size()));
    os.write(reinterpret_cast<const char*>(f.payload_.data()), std::streamsize(f.payload_.size()));
  }

  static EncodedFrame read(Reader& in) {
    EncodedFrame f;
    const auto kind = in.get<std::uint8_t>("kind");
    if (kind > 1) in.fail("kind must be 0 (depth) or 1 (points), got " + std::to_string(kind));
    f.kind_ = kind == 0 ? EncodedFrame::Kind::Depth : EncodedFrame::Kind::Points;
    f.compressed_ = in.get<std::uint8_t>("compressed") != 0;
    const bool has_camera = in.get<std::uint8_t>("has camera") != 0;
    f.stride_ = in.get<std::int32_t>("stride");
    if (f.stride_ < 1 || f.stride_ > 1000) in.fail("stride must be in [1, 1000], got " + std::to_string(f.stride_));
    f.count_ = in.get<std::uint32_t>("count");
    f.unit_m_ = in.get<double>("unit_m");
    if (!(f.unit_m_ > 0.0 && f.unit_m_ <= 1.0)) in.fail("unit_m must be in (0, 1], got " + std::to_string(f.unit_m_));
    if (has_camera) {
      auto K = std::make_shared<CameraIntrinsics>();
      K->width = in.get<std::int32_t>("camera width");
      K->height = in.get<std::int32_t>("camera height");
      K->fx = in.get<double>("fx");
      K->fy = in.get<double>("fy");
      K->cx = in.get<double>("cx");
      K->cy = in.get<double>("cy");
      try {
        K->validate();
      } catch (const std::invalid_argument& e) {
        in.fail(std::string("camera: ") + e.what());
      }
      if (f.kind_ == EncodedFrame::Kind::Depth && std::uint64_t(K->width) * std::uint64_t(K->height) != f.count_)
        in.fail("count " + std::to_string(f.count_) + " is not the camera's " + std::to_string(K->width) + "x" +
                std::to_string(K->height) + " pixels");
      f.intrinsics_ = std::move(K);
    } else if (f.kind_ == EncodedFrame::Kind::Depth) {
      in.fail("a depth frame without its camera");
    }
    const auto n = in.get<std::uint64_t>("payload size");
    if (n > in.left()) in.fail("payload of " + std::to_string(n) + " bytes, the file has " + std::to_string(in.left()) + " left");
    // What decoding will allocate, bounded by the payload before anything is allocated for it.
    const std::uint64_t codes = std::uint64_t(f.count_) * codeBytes(f.kind_ == EncodedFrame::Kind::Depth);
    if (!f.compressed_ && n != codes)
      in.fail("raw payload of " + std::to_string(n) + " bytes, count " + std::to_string(f.count_) + " needs " +
              std::to_string(codes));
    if (f.compressed_ && codes > kMaxInflateRatio * n)
      in.fail("count " + std::to_string(f.count_) + " needs " + std::to_string(codes) +
              " bytes of codes, more than a compressed payload of " + std::to_string(n) + " bytes holds");
    f.payload_.resize(n);
    in.bytes(f.payload_.data(), n, "payload");
    return f;
  }

  /// Whether the payload decodes to `count` codes; for files without checksums, whose payloads
  /// nothing else vouches for.
  static void checkDecodes(Reader& in, const EncodedFrame& f) {
    try {
      if (f.kind_ == EncodedFrame::Kind::Depth)
        (void)f.decodeDepth();
      else
        (void)f.decode();
    } catch (const std::runtime_error& e) {
      in.fail(std::string("payload: ") + e.what());
    }
  }
};

void KeyframeStore::save(const std::filesystem::path& path) const {
  AtomicFileSet files;
  stageSave(path, files);
  files.commit();
}

void KeyframeStore::stageSave(const std::filesystem::path& path, AtomicFileSet& files) const {
  if (!littleEndian()) throw FileError("cannot write " + path.string() + ": keyframe stores are little-endian");
  const std::string& unit = files.unitId();
  files.add(path, [&](std::ostream& os) {
    os.write(kMagic, sizeof(kMagic));
    put(os, kVersion);
    put(os, std::uint32_t(unit.size()));
    put(os, std::uint64_t(frames_.size()));
    os.write(unit.data(), std::streamsize(unit.size()));
    std::ostringstream record;
    for (const auto& [id, kf] : frames_) {
      record.str(std::string());
      put(record, std::uint64_t(kf.id));
      put(record, kf.timestamp);
      putPose(record, kf.T_W_S_integrated);
      putPose(record, kf.T_W_S_latest);
      put(record, std::uint8_t(kf.integrated ? 1 : 0));
      KeyframeStoreFile::write(record, kf.data);
      const std::string bytes = record.str();
      os.write(bytes.data(), std::streamsize(bytes.size()));
      put(os, std::uint32_t(libdeflate_crc32(0, bytes.data(), bytes.size())));
    }
  });
}

namespace {

struct StoreHeader {
  std::uint32_t version = 0;
  std::uint64_t count = 0;
  std::string unit_id;
};

StoreHeader readHeader(Reader& in) {
  StoreHeader header;
  char magic[8];
  in.bytes(magic, sizeof(magic), "the header");
  if (std::memcmp(magic, kMagic, sizeof(magic)) != 0) in.fail("not a vdbmap keyframe store (no VDBMAPKF header)");
  const auto version = header.version = in.get<std::uint32_t>("version");
  if (version < 1 || version > kVersion)
    in.fail("keyframe store of version " + std::to_string(version) + ", this build reads versions 1 to " +
            std::to_string(kVersion));
  const auto id_bytes = in.get<std::uint32_t>("unit id size");
  if (version == 1 ? id_bytes != 0 : id_bytes > kMaxUnitIdBytes)
    in.fail("unit id of " + std::to_string(id_bytes) + " bytes (at most " + std::to_string(kMaxUnitIdBytes) + ")");
  header.count = in.get<std::uint64_t>("keyframe count");
  header.unit_id.assign(id_bytes, '\0');
  in.bytes(header.unit_id.data(), id_bytes, "the unit id");
  for (char c : header.unit_id)
    if (!std::isxdigit(static_cast<unsigned char>(c))) in.fail("the unit id is not hexadecimal");
  return header;
}

}  // namespace

std::string KeyframeStore::savedUnitId(const std::filesystem::path& path) {
  Reader in(path);
  return readHeader(in).unit_id;
}

KeyframeStore KeyframeStore::load(const std::filesystem::path& path) {
  if (!littleEndian()) throw FileError("cannot read " + path.string() + ": keyframe stores are little-endian");
  Reader in(path);
  const StoreHeader header = readHeader(in);
  const std::uint64_t count = header.count;
  const bool checksummed = header.version >= kFirstChecksummedVersion;
  if (count > in.left() / (kMinRecordBytes + (checksummed ? 4 : 0)))
    in.fail("says " + std::to_string(count) + " keyframes, more than its " + std::to_string(in.left()) + " bytes can hold");
  KeyframeStore store;
  for (std::uint64_t k = 0; k < count; ++k) {
    in.setRecord("keyframe " + std::to_string(k));
    in.startChecksum();
    Keyframe kf;
    kf.id = in.get<std::uint64_t>("id");
    in.setRecord("keyframe " + std::to_string(k) + " (id " + std::to_string(kf.id) + ")");
    kf.timestamp = in.get<double>("timestamp");
    if (!std::isfinite(kf.timestamp)) in.fail("timestamp is not finite");
    kf.T_W_S_integrated = in.pose("T_W_S_integrated");
    kf.T_W_S_latest = in.pose("T_W_S_latest");
    kf.integrated = in.get<std::uint8_t>("integrated") != 0;
    kf.data = KeyframeStoreFile::read(in);
    if (checksummed) {
      const std::uint32_t computed = in.checksum();
      if (in.get<std::uint32_t>("checksum") != computed) in.fail("the record's CRC-32 does not match: it is damaged");
    } else {
      KeyframeStoreFile::checkDecodes(in, kf.data);
    }
    if (store.contains(kf.id)) in.fail("id listed twice");
    store.add(std::move(kf));
  }
  in.setRecord("");
  if (in.left() != 0) in.fail(std::to_string(in.left()) + " bytes after the last keyframe");
  return store;
}

}  // namespace vdbmap
