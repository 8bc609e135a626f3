#include "internal/vdb_file_check.hpp"

#include "vdbmap/file_error.hpp"

#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>

namespace vdbmap::internal {
namespace {

constexpr std::uint32_t kOldestCheckedVersion = 220;  // OPENVDB_FILE_VERSION_SELECTIVE_COMPRESSION
constexpr std::uint32_t kPerGridCompression = 222;    // OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION
constexpr std::uint32_t kInstancing = 216;            // OPENVDB_FILE_VERSION_GRID_INSTANCING
constexpr std::uint64_t kMagic = 0x56444220;

/// Reads little-endian values from the file, never past `end`, naming `path` in every error.
class Walker {
 public:
  Walker(const std::filesystem::path& path, std::uint64_t size) : path_(path), in_(path, std::ios::binary), end_(size) {
    if (!in_) throw FileError("cannot open map " + path.string());
  }
  template <typename T>
  T get(const std::string& what) {
    T v{};
    need(sizeof(T), what);
    in_.read(reinterpret_cast<char*>(&v), sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  /// A length-prefixed string: the length is checked before anything is read.
  std::string string(const std::string& what) {
    const auto n = get<std::uint32_t>(what + " length");
    need(n, what + " (" + std::to_string(n) + " bytes)");
    std::string s(n, '\0');
    in_.read(s.data(), std::streamsize(n));
    pos_ += n;
    return s;
  }
  void skip(std::uint64_t n, const std::string& what) {
    need(n, what + " (" + std::to_string(n) + " bytes)");
    in_.seekg(std::streamoff(n), std::ios::cur);
    pos_ += n;
  }
  void seek(std::uint64_t to, const std::string& what) {
    if (to > end_) fail(what + " points to byte " + std::to_string(to) + ", beyond the file's " + std::to_string(end_));
    in_.seekg(std::streamoff(to));
    pos_ = to;
  }
  /// Limits reads to [pos, end) while walking a grid's block.
  void setEnd(std::uint64_t end) { end_ = end; }
  std::uint64_t left() const { return end_ - pos_; }
  [[noreturn]] void fail(const std::string& what) const {
    throw FileError("cannot read map " + path_.string() + ": " + what + " (truncated or damaged file)");
  }

 private:
  void need(std::uint64_t n, const std::string& what) {
    if (n > left()) fail(what + " runs past the end, " + std::to_string(left()) + " bytes left");
    if (!in_) fail("read error before " + what);
  }
  std::filesystem::path path_;
  std::ifstream in_;
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

/// A MetaMap: count, then per entry its name, type name and sized value.
void walkMetadata(Walker& w, const std::string& where) {
  const auto count = w.get<std::int32_t>(where + " metadata count");
  // The smallest entry is three 4-byte lengths.
  if (count < 0 || std::uint64_t(count) > w.left() / 12)
    w.fail(where + " declares " + std::to_string(count) + " metadata entries, more than " +
           std::to_string(w.left()) + " bytes can hold");
  for (std::int32_t k = 0; k < count; ++k) {
    const std::string entry = where + " metadata entry " + std::to_string(k);
    const std::string name = w.string(entry + " name");
    const std::string type = w.string(entry + " ('" + name + "') type");
    const auto bytes = w.get<std::uint32_t>(entry + " ('" + name + "') value size");
    // OpenVDB reads sizeof(T) for its fixed-size types, whatever size the entry declares.
    const std::uint32_t fixed = fixedMetadataBytes(type);
    if (fixed != 0 && bytes != fixed)
      w.fail(entry + " ('" + name + "') of type " + type + " declares " + std::to_string(bytes) + " bytes, not " +
             std::to_string(fixed));
    w.skip(bytes, entry + " ('" + name + "') value");
  }
}

}  // namespace

void checkVdbFileStructure(const std::filesystem::path& path) {
  std::error_code ec;
  const std::uint64_t size = std::filesystem::file_size(path, ec);
  if (ec) throw FileError("cannot read map " + path.string() + ": " + ec.message());
  Walker w(path, size);
  if (w.get<std::uint64_t>("the header") != kMagic) w.fail("no OpenVDB header (not a .vdb file)");
  const auto version = w.get<std::uint32_t>("the file version");
  if (version < kOldestCheckedVersion)
    w.fail("OpenVDB file version " + std::to_string(version) + ", older than the " +
           std::to_string(kOldestCheckedVersion) + " this build checks and reads (vdbmap writes 224)");
  w.get<std::uint32_t>("the library version");
  w.get<std::uint32_t>("the library version");
  const bool has_offsets = w.get<char>("the grid offsets flag") != 0;
  w.skip(36, "the file id");
  walkMetadata(w, "the file");
  const auto grids = w.get<std::int32_t>("the grid count");
  if (grids < 0 || std::uint64_t(grids) > w.left() / 36)
    w.fail("declares " + std::to_string(grids) + " grids, more than " + std::to_string(w.left()) + " bytes can hold");
  // Without offsets the grids follow their descriptors unchecked; OpenVDB writes offsets since 212.
  if (!has_offsets) w.fail("no grid offsets (written by an OpenVDB older than this build checks)");
  for (std::int32_t g = 0; g < grids; ++g) {
    const std::string grid = "grid " + std::to_string(g);
    const std::string name = w.string(grid + " name");
    const std::string label = grid + " ('" + name + "')";
    w.string(label + " type");
    if (version >= kInstancing) w.string(label + " instance parent");
    const auto grid_pos = w.get<std::int64_t>(label + " offset");
    const auto block_pos = w.get<std::int64_t>(label + " data offset");
    const auto end_pos = w.get<std::int64_t>(label + " end offset");
    if (grid_pos < 0 || block_pos < grid_pos || end_pos < block_pos || std::uint64_t(end_pos) > size)
      w.fail(label + " spans bytes " + std::to_string(grid_pos) + " to " + std::to_string(end_pos) +
             " (data from " + std::to_string(block_pos) + "), outside the file's " + std::to_string(size));
    // The grid's own header: compression flags, then its metadata, all before its data block.
    w.seek(std::uint64_t(grid_pos), label + " offset");
    w.setEnd(std::uint64_t(block_pos));
    if (version >= kPerGridCompression) w.get<std::uint32_t>(label + " compression flags");
    walkMetadata(w, label);
    w.setEnd(size);
    w.seek(std::uint64_t(end_pos), label + " end offset");
  }
}

}  // namespace vdbmap::internal
