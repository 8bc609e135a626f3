#include "vdbmap/io/png_io.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/io/errors.hpp"

#include "png_gray16.hpp"

#include <png.h>

#include <cerrno>
#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>

namespace vdbmap::io {
namespace {

// libpng reports errors through a callback that must not return: we keep its message and
// longjmp back to the setjmp in the function that drives libpng. Only trivially destructible
// locals live between setjmp and the calls that can jump, so the jump skips no destructor.
struct PngErrorState {
  char message[256] = {0};
};

extern "C" void pngErrorFn(png_structp png, png_const_charp msg) {
  auto* st = static_cast<PngErrorState*>(png_get_error_ptr(png));
  if (st) {
    std::strncpy(st->message, msg ? msg : "unknown libpng error", sizeof(st->message) - 1);
    st->message[sizeof(st->message) - 1] = '\0';
  }
  png_longjmp(png, 1);
}

extern "C" void pngWarningFn(png_structp, png_const_charp) {}

bool hostIsLittleEndian() {
  const std::uint16_t one = 1;
  unsigned char c;
  std::memcpy(&c, &one, 1);
  return c == 1;
}

struct FileCloser {
  std::FILE* f = nullptr;
  ~FileCloser() {
    if (f) std::fclose(f);
  }
};

// Largest output of deflate per compressed byte (zlib: "the maximum compression factor is
// 1032:1"): a PNG's pixel data cannot exceed 1032 times the file's size.
constexpr std::uint64_t kDeflateMaxRatio = 1032;

std::FILE* openForReading(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw FileError(path.string() + ": no such file");
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw FileError(path.string() + ": cannot open: " + std::strerror(errno));
  unsigned char sig[8];
  const std::size_t n = std::fread(sig, 1, 8, f);
  if (n != 8 || png_sig_cmp(sig, 0, 8) != 0) {
    std::fclose(f);
    throw FileError(path.string() + ": not a PNG file (bad signature" + (n != 8 ? ", file too short)" : ")"));
  }
  return f;
}

struct Header {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  int bit_depth = 0;
  int color_type = 0;
};

int channelsOf(int color_type) {
  switch (color_type) {
    case 0: return 1;  // gray
    case 2: return 3;  // RGB
    case 3: return 1;  // palette
    case 4: return 2;  // gray+alpha
    case 6: return 4;  // RGBA
    default: return 0;
  }
}

// Reads the IHDR chunk that follows the signature of `f` (opened by openForReading) and leaves `f`
// just after the signature again, for libpng. Refuses, naming the file, an image wider or taller
// than kMaxPngSide and one that declares more pixel data than the file could hold compressed,
// before anything is allocated: a 45-byte file claiming 100000 x 100000 pixels costs nothing.
Header readCheckedHeader(std::FILE* f, const std::filesystem::path& path) {
  // length (4), "IHDR" (4), width (4), height (4), bit depth (1), colour type (1), ... big endian.
  unsigned char b[18];
  if (std::fread(b, 1, sizeof(b), f) != sizeof(b) || std::memcmp(b + 4, "IHDR", 4) != 0)
    throw FileError(path.string() + ": corrupt or truncated PNG: no IHDR chunk");
  if (std::fseek(f, 8, SEEK_SET) != 0) throw FileError(path.string() + ": cannot seek: " + std::strerror(errno));
  auto be32 = [](const unsigned char* p) {
    return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | p[3];
  };
  Header h;
  h.width = be32(b + 8);
  h.height = be32(b + 12);
  h.bit_depth = b[16];
  h.color_type = b[17];
  const std::string size = std::to_string(h.width) + "x" + std::to_string(h.height);
  if (h.width == 0 || h.height == 0) throw FileError(path.string() + ": corrupt PNG: image size " + size);
  if (h.width > std::uint32_t(kMaxPngSide) || h.height > std::uint32_t(kMaxPngSide))
    throw FileError(path.string() + ": PNG image size " + size + " exceeds the limit of " +
                    std::to_string(kMaxPngSide) + "x" + std::to_string(kMaxPngSide));
  const int channels = channelsOf(h.color_type);
  const int bits = h.bit_depth;
  if (channels == 0 || (bits != 1 && bits != 2 && bits != 4 && bits != 8 && bits != 16))
    throw FileError(path.string() + ": corrupt PNG: colour type " + std::to_string(h.color_type) + " with bit depth " +
                    std::to_string(h.bit_depth));
  // The pixel bits are a lower bound of the decompressed data (rows add a filter byte each).
  const std::uint64_t pixel_bytes = std::uint64_t(h.width) * h.height * std::uint64_t(channels * h.bit_depth) / 8;
  std::error_code ec;
  const std::uintmax_t file_bytes = std::filesystem::file_size(path, ec);
  if (!ec && pixel_bytes > kDeflateMaxRatio * std::uint64_t(file_bytes))
    throw FileError(path.string() + ": corrupt PNG: its header declares " + size + " pixels (" +
                    std::to_string(pixel_bytes) + " bytes of pixel data), more than a " + std::to_string(file_bytes) +
                    "-byte file can hold compressed");
  return h;
}

// What the decoder hands back; buffers are owned by the caller so that the jump frees nothing.
struct Decoded {
  png_uint_32 width = 0;
  png_uint_32 height = 0;
  int channels = 0;
  int bit_depth = 0;
  int color_type = 0;
};

enum class Mode { Any, Depth16 };

// Decodes the PNG after its signature. In Depth16 mode the image must be 16-bit gray and is
// decoded in native byte order straight into `buf16`; otherwise 8-bit data go to `buf8` and
// 16-bit data to `buf16`. Returns false with `st.message` set on a libpng error, and sets
// `wrong_kind` when Depth16 mode meets another kind of PNG.
bool decode(std::FILE* f, Mode mode, PngErrorState& st, Decoded& d, std::vector<std::uint8_t>& buf8,
            std::vector<std::uint16_t>& buf16, std::vector<png_bytep>& rows, bool& wrong_kind) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &st, pngErrorFn, pngWarningFn);
  if (!png) {
    std::strcpy(st.message, "out of memory");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    std::strcpy(st.message, "out of memory");
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_init_io(png, f);
  png_set_sig_bytes(png, 8);
  // The same bound readCheckedHeader() applied, so libpng never allocates for a larger image.
  png_set_user_limits(png, png_uint_32(kMaxPngSide), png_uint_32(kMaxPngSide));
  png_read_info(png, info);
  d.width = png_get_image_width(png, info);
  d.height = png_get_image_height(png, info);
  d.color_type = png_get_color_type(png, info);
  d.bit_depth = png_get_bit_depth(png, info);
  if (mode == Mode::Depth16) {
    if (d.color_type != PNG_COLOR_TYPE_GRAY || d.bit_depth != 16) {
      wrong_kind = true;
      png_destroy_read_struct(&png, &info, nullptr);
      return false;
    }
  } else {
    png_set_expand(png);  // palette -> RGB, gray < 8 bits -> 8 bits, tRNS -> alpha
  }
  if (d.bit_depth == 16 && hostIsLittleEndian()) png_set_swap(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  d.channels = png_get_channels(png, info);
  d.bit_depth = png_get_bit_depth(png, info);
  const std::size_t row_bytes = png_get_rowbytes(png, info);
  rows.resize(d.height);
  if (d.bit_depth == 16) {
    buf16.resize(std::size_t(d.width) * d.height * std::size_t(d.channels));
    for (png_uint_32 y = 0; y < d.height; ++y)
      rows[y] = reinterpret_cast<png_bytep>(buf16.data() + std::size_t(y) * d.width * std::size_t(d.channels));
    if (row_bytes != std::size_t(d.width) * std::size_t(d.channels) * 2) png_error(png, "unexpected row size");
  } else {
    buf8.resize(std::size_t(d.height) * row_bytes);
    for (png_uint_32 y = 0; y < d.height; ++y) rows[y] = buf8.data() + std::size_t(y) * row_bytes;
  }
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);  // checks the chunks after the image data (catches truncation)
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

const char* colorTypeName(int color_type) {
  switch (color_type) {
    case PNG_COLOR_TYPE_GRAY: return "gray";
    case PNG_COLOR_TYPE_GRAY_ALPHA: return "gray+alpha";
    case PNG_COLOR_TYPE_RGB: return "RGB";
    case PNG_COLOR_TYPE_RGBA: return "RGBA";
    case PNG_COLOR_TYPE_PALETTE: return "palette";
    default: return "unknown";
  }
}

// Writes `rows` of a (width x height) image to `f`; returns false with st.message on error.
bool encode(std::FILE* f, PngErrorState& st, png_uint_32 width, png_uint_32 height, int bit_depth, int color_type,
            std::vector<png_bytep>& rows) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &st, pngErrorFn, pngWarningFn);
  if (!png) {
    std::strcpy(st.message, "out of memory");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    std::strcpy(st.message, "out of memory");
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, f);
  // Level 3 is ~2x faster to write than zlib's default with files a few % larger.
  png_set_compression_level(png, 3);
  // Paeth alone encodes the simulator's 16-bit depth frames 30-60 % faster than libpng's
  // adaptive choice among all five filters, with files within 1 % of its size.
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_PAETH);
  png_set_IHDR(png, info, width, height, bit_depth, color_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (bit_depth == 16 && hostIsLittleEndian()) png_set_swap(png);
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

int colorTypeFor(int channels) {
  switch (channels) {
    case 1: return PNG_COLOR_TYPE_GRAY;
    case 2: return PNG_COLOR_TYPE_GRAY_ALPHA;
    case 3: return PNG_COLOR_TYPE_RGB;
    case 4: return PNG_COLOR_TYPE_RGBA;
    default: return -1;
  }
}

// Encodes into a temporary file beside `path` and renames it; `rows` point at row data laid
// out as libpng expects (16-bit samples in host order).
void writeRowsAtomically(const std::filesystem::path& path, png_uint_32 width, png_uint_32 height, int bit_depth,
                         int color_type, std::vector<png_bytep>& rows) {
  if (path.has_parent_path() && !std::filesystem::is_directory(path.parent_path()))
    throw FileError("cannot write " + path.string() + ": folder " + path.parent_path().string() +
                    " does not exist");
  const std::filesystem::path tmp = temporaryPathFor(path);
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw FileError("cannot write " + path.string() + ": " + std::strerror(errno));
  PngErrorState st;
  bool ok = encode(f, st, width, height, bit_depth, color_type, rows);
  ok = (std::fflush(f) == 0) && ok;
  ok = (std::fclose(f) == 0) && ok;
  if (!ok) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw FileError("cannot write " + path.string() + ": " + (st.message[0] ? st.message : "write error (disk full?)"));
  }
  commitTemporary(tmp, path);
}

}  // namespace

void readPngSize(const std::filesystem::path& path, int& width, int& height) {
  FileCloser file{openForReading(path)};
  const Header h = readCheckedHeader(file.f, path);
  width = int(h.width);
  height = int(h.height);
}

PngImage readPng(const std::filesystem::path& path) {
  FileCloser file{openForReading(path)};
  readCheckedHeader(file.f, path);
  PngErrorState st;
  Decoded d;
  std::vector<std::uint8_t> buf8;
  std::vector<std::uint16_t> buf16;
  std::vector<png_bytep> rows;
  bool wrong_kind = false;
  if (!decode(file.f, Mode::Any, st, d, buf8, buf16, rows, wrong_kind))
    throw FileError(path.string() + ": corrupt or truncated PNG: " + st.message);
  PngImage img;
  img.width = int(d.width);
  img.height = int(d.height);
  img.channels = d.channels;
  img.bit_depth = d.bit_depth;
  if (d.bit_depth == 16) {
    img.samples = std::move(buf16);
  } else {
    const std::size_t row_samples = std::size_t(d.width) * std::size_t(d.channels);
    const std::size_t row_bytes = buf8.size() / std::max<std::size_t>(1, d.height);
    img.samples.resize(row_samples * d.height);
    for (std::size_t y = 0; y < d.height; ++y)
      for (std::size_t i = 0; i < row_samples; ++i) img.samples[y * row_samples + i] = buf8[y * row_bytes + i];
  }
  return img;
}

namespace {

/// Files up to this size are decoded from memory when they are plain 16-bit gray PNGs.
constexpr long kMaxFastPngBytes = 64L << 20;

/// The whole of `f` (signature included) when it holds at most max_bytes; else false. Leaves `f`
/// anywhere.
bool readWhole(std::FILE* f, long max_bytes, std::vector<std::uint8_t>& bytes) {
  if (std::fseek(f, 0, SEEK_END) != 0) return false;
  const long size = std::ftell(f);
  if (size < 0 || size > max_bytes || std::fseek(f, 0, SEEK_SET) != 0) return false;
  bytes.resize(std::size_t(size));
  return std::fread(bytes.data(), 1, bytes.size(), f) == bytes.size();
}

// readDepthPng, with the header's size checked against `expected` (width, height) when given.
DepthImage readDepth(const std::filesystem::path& path, double depth_scale, std::uint16_t invalid_raw,
                     const int* expected) {
  if (!(depth_scale > 0.0) || !std::isfinite(depth_scale))
    throw std::invalid_argument("readDepthPng: depth_scale must be finite and > 0, got " + std::to_string(depth_scale));
  FileCloser file{openForReading(path)};
  const Header h = readCheckedHeader(file.f, path);
  if (expected && (std::int64_t(h.width) != expected[0] || std::int64_t(h.height) != expected[1]))
    throw FileError(path.string() + ": depth image is " + std::to_string(h.width) + "x" + std::to_string(h.height) +
                    " but the camera is " + std::to_string(expected[0]) + "x" + std::to_string(expected[1]));
  std::vector<std::uint16_t> raw;
  {
    // The common case, a plain 16-bit gray PNG, without libpng (internal/png_gray16.hpp); anything
    // else, and every error, goes to libpng below, which names what is wrong.
    std::vector<std::uint8_t> bytes;
    std::uint32_t width = 0, height = 0;
    if (readWhole(file.f, kMaxFastPngBytes, bytes) &&
        internal::decodeGray16Png(bytes.data(), bytes.size(), std::uint32_t(kMaxPngSide), width, height, raw))
      return depthFromRaw(int(width), int(height), raw.data(), depth_scale, invalid_raw);
    if (std::fseek(file.f, 8, SEEK_SET) != 0) throw FileError(path.string() + ": cannot seek: " + std::strerror(errno));
  }
  PngErrorState st;
  Decoded d;
  std::vector<std::uint8_t> buf8;
  std::vector<png_bytep> rows;
  bool wrong_kind = false;
  if (!decode(file.f, Mode::Depth16, st, d, buf8, raw, rows, wrong_kind)) {
    if (wrong_kind)
      throw FileError(path.string() + ": expected a 16-bit gray depth PNG, got " + std::to_string(d.bit_depth) +
                      "-bit " + colorTypeName(d.color_type));
    throw FileError(path.string() + ": corrupt or truncated PNG: " + st.message);
  }
  return depthFromRaw(int(d.width), int(d.height), raw.data(), depth_scale, invalid_raw);
}

}  // namespace

DepthImage readDepthPng(const std::filesystem::path& path, double depth_scale, std::uint16_t invalid_raw) {
  return readDepth(path, depth_scale, invalid_raw, nullptr);
}

DepthImage readDepthPng(const std::filesystem::path& path, double depth_scale, std::uint16_t invalid_raw,
                        int expected_width, int expected_height) {
  const int expected[2] = {expected_width, expected_height};
  return readDepth(path, depth_scale, invalid_raw, expected);
}

void writePng(const std::filesystem::path& path, const PngImage& image) {
  const int color_type = colorTypeFor(image.channels);
  if (color_type < 0) throw std::invalid_argument("writePng: channels must be 1..4, got " + std::to_string(image.channels));
  if (image.bit_depth != 8 && image.bit_depth != 16)
    throw std::invalid_argument("writePng: bit_depth must be 8 or 16, got " + std::to_string(image.bit_depth));
  if (image.width <= 0 || image.height <= 0 || image.width > kMaxPngSide || image.height > kMaxPngSide)
    throw std::invalid_argument("writePng: width and height must be in [1, " + std::to_string(kMaxPngSide) + "]");
  const std::size_t row_samples = std::size_t(image.width) * std::size_t(image.channels);
  if (image.samples.size() != row_samples * std::size_t(image.height))
    throw std::invalid_argument("writePng: samples.size() must be width * height * channels");
  std::vector<png_bytep> rows(std::size_t(image.height));
  std::vector<std::uint16_t> buf16;
  std::vector<std::uint8_t> buf8;
  if (image.bit_depth == 16) {
    buf16 = image.samples;
    for (std::size_t y = 0; y < rows.size(); ++y) rows[y] = reinterpret_cast<png_bytep>(buf16.data() + y * row_samples);
  } else {
    buf8.resize(image.samples.size());
    for (std::size_t i = 0; i < buf8.size(); ++i) {
      if (image.samples[i] > 255) throw std::invalid_argument("writePng: 8-bit sample out of range at index " + std::to_string(i));
      buf8[i] = std::uint8_t(image.samples[i]);
    }
    for (std::size_t y = 0; y < rows.size(); ++y) rows[y] = buf8.data() + y * row_samples;
  }
  writeRowsAtomically(path, png_uint_32(image.width), png_uint_32(image.height), image.bit_depth, color_type, rows);
}

void writeDepthPng(const std::filesystem::path& path, const DepthImage& depth, double depth_scale,
                   std::size_t* clipped_count) {
  if (!(depth_scale > 0.0) || !std::isfinite(depth_scale))
    throw std::invalid_argument("writeDepthPng: depth_scale must be finite and > 0, got " + std::to_string(depth_scale));
  if (depth.width <= 0 || depth.height <= 0 || depth.depth_m.size() != std::size_t(depth.width) * std::size_t(depth.height))
    throw std::invalid_argument("writeDepthPng: depth image size is inconsistent");
  if (depth.width > kMaxPngSide || depth.height > kMaxPngSide)
    throw std::invalid_argument("writeDepthPng: width and height must be at most " + std::to_string(kMaxPngSide));
  std::vector<std::uint16_t> raw(depth.depth_m.size());
  std::size_t clipped = 0;
  const double inv = 1.0 / depth_scale;
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const float z = depth.depth_m[i];
    if (!(z > 0.0f) || !std::isfinite(z)) {
      raw[i] = 0;
      continue;
    }
    const double v = std::round(double(z) * inv);
    if (v > 65535.0) {
      raw[i] = 0;
      ++clipped;
    } else {
      raw[i] = std::uint16_t(v);
    }
  }
  if (clipped_count) *clipped_count = clipped;
  std::vector<png_bytep> rows(std::size_t(depth.height));
  for (std::size_t y = 0; y < rows.size(); ++y) rows[y] = reinterpret_cast<png_bytep>(raw.data() + y * std::size_t(depth.width));
  writeRowsAtomically(path, png_uint_32(depth.width), png_uint_32(depth.height), 16, PNG_COLOR_TYPE_GRAY, rows);
}

}  // namespace vdbmap::io
