#include "internal/vdb_file_check.hpp"

#include "vdbmap/file_error.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <bitset>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace vdbmap::internal {
namespace {

// OpenVDB file format versions (openvdb/version.h) the walk depends on.
constexpr std::uint32_t kOldestCheckedVersion = 222;  // OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION (OpenVDB 3.0)
constexpr std::uint32_t kInstancing = 216;            // OPENVDB_FILE_VERSION_GRID_INSTANCING
constexpr std::uint64_t kMagic = 0x56444220;

// io::Compression flags and the per-node mask compression codes of openvdb/io/Compression.h.
constexpr std::uint32_t kZip = 0x1, kActiveMask = 0x2, kBlosc = 0x4;
enum NodeMetadata : std::int8_t {
  kNoMaskOrInactiveVals = 0,
  kNoMaskAndMinusBg = 1,
  kNoMaskAndOneInactiveVal = 2,
  kMaskAndNoInactiveVals = 3,
  kMaskAndOneInactiveVal = 4,
  kMaskAndTwoInactiveVals = 5,
  kNoMaskAndAllVals = 6,
};

// The smallest leaf in a grid's data: value mask, node metadata byte and a chunk size.
constexpr std::uint64_t kMinLeafBytes = 64 + 1 + 8;

/// The file, mapped read-only; empty files map nothing.
class MappedFile {
 public:
  explicit MappedFile(const std::filesystem::path& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) throw FileError("cannot open map " + path.string() + ": " + std::strerror(errno));
    struct stat st {};
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
      ::close(fd);
      throw FileError("cannot open map " + path.string() + ": not a regular file");
    }
    size_ = std::uint64_t(st.st_size);
    if (size_ > 0) {
      void* p = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
      if (p == MAP_FAILED) {
        ::close(fd);
        throw FileError("cannot read map " + path.string() + ": " + std::strerror(errno));
      }
      data_ = static_cast<const unsigned char*>(p);
    }
    ::close(fd);
  }
  ~MappedFile() {
    if (data_ != nullptr) ::munmap(const_cast<unsigned char*>(data_), size_);
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  const unsigned char* data() const { return data_; }
  std::uint64_t size() const { return size_; }

 private:
  const unsigned char* data_ = nullptr;
  std::uint64_t size_ = 0;
};

/// Names a part of the file in error messages: a parent, a text and an optional number ("grid 0
/// ('tsdf') leaf 17 value mask"). The string is built only when an error is reported, so a walk
/// over millions of leaves builds none. A Where refers to its parent and text: it lives within the
/// full expression that makes it, or as a named object below a named parent.
class Where {
 public:
  Where(const char* text) : text_(text) {}                 // NOLINT: a literal names a part
  Where(const std::string& text) : text_(text.c_str()) {}  // NOLINT: so does a label read from the file
  Where(const Where& parent, const char* text) : parent_(&parent), text_(text) {}
  Where(const Where& parent, const char* text, std::uint64_t index)
      : parent_(&parent), text_(text), index_(index), has_index_(true) {}
  std::string str() const {
    std::string s = parent_ ? parent_->str() : std::string();
    s += text_;
    if (has_index_) s += std::to_string(index_);
    return s;
  }

 private:
  const Where* parent_ = nullptr;
  const char* text_ = "";
  std::uint64_t index_ = 0;
  bool has_index_ = false;
};
/// `where + " part"` names a part lazily; adding a std::string builds the message (errors only).
Where operator+(const Where& parent, const char* text) { return Where(parent, text); }
std::string operator+(const Where& where, const std::string& more) { return where.str() + more; }

/// Reads little-endian values from the mapped file, never past `end`, naming `path` in every error.
class Walker {
 public:
  Walker(const std::filesystem::path& path, const MappedFile& file) : path_(path), file_(file), end_(file.size()) {}
  template <typename T>
  T get(const Where& what) {
    T v{};
    need(sizeof(T), what);
    std::memcpy(&v, file_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  /// A length-prefixed string: the length is checked before anything is read.
  std::string string(const Where& what) {
    const auto n = get<std::uint32_t>(what + " length");
    need(n, what, true);
    std::string s(reinterpret_cast<const char*>(file_.data() + pos_), n);
    pos_ += n;
    return s;
  }
  /// The next `n` bytes, which stay mapped while the walker lives.
  const unsigned char* take(std::uint64_t n, const Where& what) {
    need(n, what, true);
    const unsigned char* p = file_.data() + pos_;
    pos_ += n;
    return p;
  }
  void skip(std::uint64_t n, const Where& what) { take(n, what); }
  void seek(std::uint64_t to, const Where& what) {
    if (to > file_.size())
      fail(what + " points to byte " + std::to_string(to) + ", beyond the file's " + std::to_string(file_.size()));
    pos_ = to;
  }
  /// Limits reads to [pos, end) while walking one part of a grid.
  void setEnd(std::uint64_t end) { end_ = end; }
  std::uint64_t pos() const { return pos_; }
  std::uint64_t left() const { return end_ > pos_ ? end_ - pos_ : 0; }
  [[noreturn]] void fail(const Where& what) const {
    throw FileError("cannot read map " + path_.string() + ": " + what.str() + " (truncated or damaged file)");
  }

 private:
  /// `n` more bytes must be there; `show_size` names n in the error.
  void need(std::uint64_t n, const Where& what, bool show_size = false) {
    if (n <= left()) return;
    fail(what.str() + (show_size ? " (" + std::to_string(n) + " bytes)" : std::string()) + " runs past the end, " +
         std::to_string(left()) + " bytes left");
  }
  const std::filesystem::path& path_;
  const MappedFile& file_;
  std::uint64_t end_ = 0, pos_ = 0;
};

/// The value size OpenVDB reads for its fixed-size metadata types; 0 for the others.
std::uint32_t fixedMetadataBytes(const std::string& type) {
  if (type == "bool") return 1;
  if (type == "int32" || type == "float") return 4;
  if (type == "int64" || type == "double") return 8;
  if (type == "vec2i" || type == "vec2s") return 8;
  if (type == "vec2d") return 16;
  if (type == "vec3i" || type == "vec3s") return 12;
  if (type == "vec3d") return 24;
  if (type == "vec4i" || type == "vec4s") return 16;
  if (type == "vec4d") return 32;
  if (type == "mat4s") return 64;
  if (type == "mat4d") return 128;
  return 0;
}

/// A Blosc chunk of `bytes` bytes must declare exactly that many compressed bytes and from
/// `expect` to `expect_max` uncompressed ones: OpenVDB sizes its buffers from the header and Blosc
/// reads what it declares.
void checkBloscChunk(Walker& w, std::uint64_t bytes, std::uint64_t expect, std::uint64_t expect_max,
                     const Where& what) {
  if (bytes < 16) w.fail(what + ": a " + std::to_string(bytes) + "-byte Blosc chunk, shorter than its 16-byte header");
  const unsigned char* h = w.take(bytes, what);
  std::uint32_t nbytes = 0, blocksize = 0, cbytes = 0;
  std::memcpy(&nbytes, h + 4, 4);
  std::memcpy(&blocksize, h + 8, 4);
  std::memcpy(&cbytes, h + 12, 4);
  if (nbytes < expect || nbytes > expect_max || cbytes != bytes || blocksize == 0)
    w.fail(what + ": a Blosc chunk of " + std::to_string(bytes) + " bytes declares " + std::to_string(cbytes) +
           " compressed and " + std::to_string(nbytes) + " uncompressed bytes (block " + std::to_string(blocksize) +
           "), expected " + std::to_string(expect) +
           (expect_max == expect ? std::string() : " to " + std::to_string(expect_max)) + " uncompressed");
}
void checkBloscChunk(Walker& w, std::uint64_t bytes, std::uint64_t expect, const Where& what) {
  checkBloscChunk(w, bytes, expect, expect, what);
}

/// OpenVDB pads the arrays of delayed-load metadata to 128 bytes before compressing them
/// (points::bloscCompress's minimum).
std::uint64_t paddedArrayBytes(std::uint64_t bytes) { return std::max<std::uint64_t>(bytes, 128); }

/// io::DelayedLoadMetadata: a leaf count, the leaves' compression codes and (optionally) their
/// compressed sizes, each raw or as one Blosc chunk. OpenVDB allocates from every count it holds.
void walkDelayedLoadMetadata(Walker& w, std::uint32_t bytes, std::uint64_t max_leaves, const Where& what) {
  if (bytes == 0) return;
  const std::uint64_t end = w.pos() + bytes;
  const std::uint64_t outer_end = w.pos() + w.left();
  w.setEnd(end);
  const auto count = w.get<std::uint32_t>(what + " leaf count");
  if (count > max_leaves)
    w.fail(what + " declares " + std::to_string(count) + " leaves, more than the " + std::to_string(max_leaves) +
           " its grid's bytes can hold");
  const auto mask_bytes = w.get<std::uint32_t>(what + " mask size");
  if (mask_bytes > 0)
    checkBloscChunk(w, mask_bytes, count, paddedArrayBytes(count), what + " masks");
  else
    w.skip(count, what + " masks");
  const auto size_bytes = w.get<std::uint32_t>(what + " compressed sizes size");
  if (size_bytes == std::numeric_limits<std::uint32_t>::max()) {
    // no compressed sizes stored
  } else if (size_bytes > 0) {
    checkBloscChunk(w, size_bytes, std::uint64_t(count) * 8, paddedArrayBytes(std::uint64_t(count) * 8),
                    what + " compressed sizes");
  } else {
    w.skip(std::uint64_t(count) * 8, what + " compressed sizes");
  }
  w.setEnd(outer_end);
  w.seek(end, what + " end");
}

struct MetadataFacts {
  bool saved_as_half = false;
};

/// A MetaMap: count, then per entry its name, type name and sized value. `max_leaves` bounds the
/// leaf count of delayed-load metadata.
MetadataFacts walkMetadata(Walker& w, const Where& where, std::uint64_t max_leaves) {
  MetadataFacts facts;
  const auto count = w.get<std::int32_t>(where + " metadata count");
  // The smallest entry is three 4-byte lengths.
  if (count < 0 || std::uint64_t(count) > w.left() / 12)
    w.fail(where + " declares " + std::to_string(count) + " metadata entries, more than " + std::to_string(w.left()) +
           " bytes can hold");
  for (std::int32_t k = 0; k < count; ++k) {
    const Where entry(where, " metadata entry ", std::uint64_t(k));
    const std::string name = w.string(entry + " name");
    const std::string label = entry.str() + " ('" + name + "')";
    const std::string type = w.string(label + " type");
    const auto bytes = w.get<std::uint32_t>(label + " value size");
    // OpenVDB reads sizeof(T) for its fixed-size types, whatever size the entry declares.
    const std::uint32_t fixed = fixedMetadataBytes(type);
    if (fixed != 0 && bytes != fixed)
      w.fail(label + " of type " + type + " declares " + std::to_string(bytes) + " bytes, not " +
             std::to_string(fixed));
    if (type == "__delayedload") {
      walkDelayedLoadMetadata(w, bytes, max_leaves, label);
    } else if (type == "bool" && name == "is_saved_as_half_float") {
      facts.saved_as_half = w.get<char>(label + " value") != 0;
    } else {
      w.skip(bytes, label + " value");
    }
  }
  return facts;
}

/// Bytes math::Map::read reads for the map types OpenVDB registers (openvdb/math/Maps.h); 0 for
/// the frustum map, which vdbmap neither writes nor reads.
std::uint64_t mapBytes(const std::string& type) {
  constexpr std::uint64_t kVec3d = 24, kMat4d = 128;
  if (type == "AffineMap" || type == "UnitaryMap") return kMat4d;
  if (type == "ScaleMap" || type == "UniformScaleMap") return 5 * kVec3d;
  if (type == "TranslationMap") return kVec3d;
  if (type == "ScaleTranslateMap" || type == "UniformScaleTranslateMap") return 6 * kVec3d;
  return 0;
}

/// The serialized size of one value of a grid's tree type ("Tree_float_5_4_3"); `half` for
/// floating-point grids saved as half floats. 0 for trees this walk does not know (bool, mask,
/// points, string, other node sizes).
struct ValueBytes {
  std::uint64_t full = 0;    // root background and tiles
  std::uint64_t stored = 0;  // node values, half size when saved as half floats
};
ValueBytes valueBytes(std::string type, bool half) {
  const std::string prefix = "Tree_", suffix = "_5_4_3";
  if (type.size() <= prefix.size() + suffix.size() || type.compare(0, prefix.size(), prefix) != 0 ||
      type.compare(type.size() - suffix.size(), suffix.size(), suffix) != 0)
    return {};
  type = type.substr(prefix.size(), type.size() - prefix.size() - suffix.size());
  if (type == "float") return {4, half ? 2u : 4u};
  if (type == "double") return {8, half ? 2u : 8u};
  if (type == "int32" || type == "uint32") return {4, 4};
  if (type == "int64") return {8, 8};
  if (type == "vec3s") return {12, half ? 6u : 12u};
  if (type == "vec3d") return {24, half ? 6u : 24u};
  if (type == "vec3i") return {12, 12};
  return {};
}

/// Reads a node mask of `bits` bits and returns how many are on.
std::uint64_t walkMask(Walker& w, std::uint64_t bits, const Where& what, std::vector<bool>* on = nullptr) {
  const unsigned char* m = w.take(bits / 8, what);
  std::uint64_t count = 0;
  if (on) on->assign(bits, false);
  for (std::uint64_t i = 0; i < bits / 8; ++i) {
    count += std::bitset<8>(m[i]).count();
    if (on)
      for (int b = 0; b < 8; ++b) (*on)[i * 8 + std::uint64_t(b)] = (m[i] >> b) & 1;
  }
  return count;
}

/// How one tree's values are stored (io::readCompressedValues): a node-metadata byte, up to two
/// inactive values, a selection mask, then the active (or all) values as one chunk.
struct ValueCodec {
  std::uint32_t compression = 0;
  ValueBytes value;
  bool half = false;

  void walk(Walker& w, std::uint64_t count, std::uint64_t active, const Where& what) const {
    const auto meta = w.get<std::int8_t>(what + " compression code");
    if (meta < kNoMaskOrInactiveVals || meta > kNoMaskAndAllVals)
      w.fail(what + " has compression code " + std::to_string(meta) + " (0 to 6 exist)");
    if (meta == kNoMaskAndOneInactiveVal || meta == kMaskAndOneInactiveVal || meta == kMaskAndTwoInactiveVals)
      w.skip(value.stored * (meta == kMaskAndTwoInactiveVals ? 2 : 1), what + " inactive values");
    if (meta == kMaskAndNoInactiveVals || meta == kMaskAndOneInactiveVal || meta == kMaskAndTwoInactiveVals)
      w.skip(count / 8, what + " selection mask");
    const std::uint64_t stored = (compression & kActiveMask) && meta != kNoMaskAndAllVals ? active : count;
    if (half && stored == 0) return;  // io::HalfReader reads nothing for no values
    const std::uint64_t expect = stored * value.stored;
    if (compression & (kBlosc | kZip)) {
      const auto bytes = w.get<std::int64_t>(what + " chunk size");
      if (bytes <= 0) {
        // Uncompressed: OpenVDB reads -bytes into a buffer of `expect` bytes before it compares.
        if (bytes == std::numeric_limits<std::int64_t>::min() || std::uint64_t(-bytes) != expect)
          w.fail(what + " holds " + std::to_string(bytes) + " bytes uncompressed, expected -" + std::to_string(expect));
        w.skip(expect, what + " values");
      } else if (compression & kBlosc) {
        checkBloscChunk(w, std::uint64_t(bytes), expect, what + " values");
      } else {
        w.skip(std::uint64_t(bytes), what + " values");  // zlib stops at the buffer it is given
      }
    } else {
      w.skip(expect, what + " values");
    }
  }
};

/// A grid's tree: topology [pos, block_pos), then every leaf's values [block_pos, end_pos), as
/// Tree::readTopology and Tree::readBuffers read them. Each count is bounded by the bytes that
/// must follow it before anything is walked.
void walkTree(Walker& w, const ValueCodec& codec, std::uint64_t block_pos, std::uint64_t end_pos, const Where& grid) {
  const std::uint64_t v = codec.value.full;
  w.setEnd(block_pos);
  w.get<std::int32_t>(grid + " buffer count");
  w.skip(v, grid + " background");
  const auto tiles = w.get<std::uint32_t>(grid + " root tile count");
  const auto children = w.get<std::uint32_t>(grid + " root child count");
  constexpr std::uint64_t kMinInternalBytes = 2 * 4096 + 1;
  if (std::uint64_t(tiles) * (12 + v + 1) + std::uint64_t(children) * (12 + kMinInternalBytes) > w.left())
    w.fail(grid + " declares " + std::to_string(tiles) + " root tiles and " + std::to_string(children) +
           " children, more than its " + std::to_string(w.left()) + " bytes of topology can hold");
  w.skip(std::uint64_t(tiles) * (12 + v + 1), grid + " root tiles");
  std::uint64_t leaves = 0;
  std::vector<bool> child_on, child4_on;
  for (std::uint32_t c = 0; c < children; ++c) {
    const Where node(grid, " root child ", c);
    w.skip(12, node + " origin");
    walkMask(w, 32768, node + " child mask", &child_on);
    const std::uint64_t active5 = walkMask(w, 32768, node + " value mask");
    codec.walk(w, 32768, active5, node + " tile values");
    for (std::uint64_t i = 0; i < 32768; ++i) {
      if (!child_on[i]) continue;
      const Where node4(node, " child ", i);
      walkMask(w, 4096, node4 + " child mask", &child4_on);
      const std::uint64_t active4 = walkMask(w, 4096, node4 + " value mask");
      codec.walk(w, 4096, active4, node4 + " tile values");
      for (std::uint64_t j = 0; j < 4096; ++j) {
        if (!child4_on[j]) continue;
        w.skip(64, node4 + " leaf mask");
        ++leaves;
      }
    }
  }
  if (w.pos() != block_pos)
    w.fail(grid + " topology ends at byte " + std::to_string(w.pos()) + ", its data starts at " +
           std::to_string(block_pos));
  w.setEnd(end_pos);
  if (leaves > w.left() / kMinLeafBytes)
    w.fail(grid + " has " + std::to_string(leaves) + " leaves, more than its " + std::to_string(w.left()) +
           " bytes of data can hold");
  for (std::uint64_t l = 0; l < leaves; ++l) {
    const Where leaf(grid, " leaf ", l);
    const std::uint64_t active = walkMask(w, 512, leaf + " value mask");
    codec.walk(w, 512, active, leaf);
  }
  if (w.pos() != end_pos)
    w.fail(grid + " data ends at byte " + std::to_string(w.pos()) + ", its end offset says " + std::to_string(end_pos));
}

}  // namespace

void checkVdbFileStructure(const std::filesystem::path& path) {
  const MappedFile file(path);
  const std::uint64_t size = file.size();
  Walker w(path, file);
  if (w.get<std::uint64_t>("the header") != kMagic) w.fail("no OpenVDB header (not a .vdb file)");
  const auto version = w.get<std::uint32_t>("the file version");
  if (version < kOldestCheckedVersion)
    w.fail("OpenVDB file version " + std::to_string(version) + ", older than the " +
           std::to_string(kOldestCheckedVersion) + " this build checks and reads (vdbmap writes 224)");
  w.get<std::uint32_t>("the library version");
  w.get<std::uint32_t>("the library version");
  const bool has_offsets = w.get<char>("the grid offsets flag") != 0;
  w.skip(36, "the file id");
  walkMetadata(w, "the file", size / kMinLeafBytes);
  const auto grids = w.get<std::int32_t>("the grid count");
  if (grids < 0 || std::uint64_t(grids) > w.left() / 36)
    w.fail("declares " + std::to_string(grids) + " grids, more than " + std::to_string(w.left()) + " bytes can hold");
  // Without offsets the grids follow their descriptors unchecked; OpenVDB writes offsets since 212.
  if (!has_offsets) w.fail("no grid offsets (written by an OpenVDB older than this build checks)");
  for (std::int32_t g = 0; g < grids; ++g) {
    const std::string grid = "grid " + std::to_string(g);
    const std::string name = w.string(grid + " name");
    const std::string label = grid + " ('" + name + "')";
    std::string type = w.string(label + " type");
    const std::string half_suffix = "_HalfFloat";  // io::HALF_FLOAT_TYPENAME_SUFFIX
    if (type.size() > half_suffix.size() &&
        type.compare(type.size() - half_suffix.size(), half_suffix.size(), half_suffix) == 0)
      type.resize(type.size() - half_suffix.size());
    const bool instance = version >= kInstancing && !w.string(label + " instance parent").empty();
    const auto grid_pos = w.get<std::int64_t>(label + " offset");
    const auto block_pos = w.get<std::int64_t>(label + " data offset");
    const auto end_pos = w.get<std::int64_t>(label + " end offset");
    if (grid_pos < 0 || block_pos < grid_pos || end_pos < block_pos || std::uint64_t(end_pos) > size)
      w.fail(label + " spans bytes " + std::to_string(grid_pos) + " to " + std::to_string(end_pos) + " (data from " +
             std::to_string(block_pos) + "), outside the file's " + std::to_string(size));
    // The grid: compression flags, metadata and transform, then (unless an instance) its tree.
    w.seek(std::uint64_t(grid_pos), label + " offset");
    w.setEnd(std::uint64_t(block_pos));
    ValueCodec codec;
    codec.compression = w.get<std::uint32_t>(label + " compression flags");
    if (codec.compression & ~(kZip | kActiveMask | kBlosc))
      w.fail(label + " has unknown compression flags " + std::to_string(codec.compression));
    codec.half = walkMetadata(w, label, std::uint64_t(end_pos - grid_pos) / kMinLeafBytes).saved_as_half;
    const std::string map = w.string(label + " transform type");
    const std::uint64_t map_bytes = mapBytes(map);
    if (map_bytes == 0) w.fail(label + " has a transform of type '" + map + "', which vdbmap does not read");
    w.skip(map_bytes, label + " transform");
    if (!instance) {
      codec.value = valueBytes(type, codec.half);
      if (codec.value.full == 0)
        w.fail(label + " is a " + type + ", a tree type vdbmap does not read (float, double, int32, int64, vec3)");
      walkTree(w, codec, std::uint64_t(block_pos), std::uint64_t(end_pos), label);
    }
    w.setEnd(size);
    w.seek(std::uint64_t(end_pos), label + " end offset");
  }
}

}  // namespace vdbmap::internal
