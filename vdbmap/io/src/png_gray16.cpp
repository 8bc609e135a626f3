#include "png_gray16.hpp"

#include <libdeflate.h>

#include <cstdlib>
#include <cstring>
#include <memory>

namespace vdbmap::io::internal {
namespace {

constexpr std::uint8_t kSignature[8] = {137, 80, 78, 71, 13, 10, 26, 10};
constexpr std::uint32_t kMaxChunkLength = 0x7fffffffu;  // the PNG specification's limit

std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | p[3];
}

bool isLetter(std::uint8_t c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); }

/// The Paeth predictor of the PNG specification, from the left (a), upper (b) and upper-left (c)
/// bytes, without branches on the data: pa = |p - a| = |b - c|, pb = |a - c|, pc = |a + b - 2c|.
inline unsigned paeth(unsigned a, unsigned b, unsigned c) {
  const int pa = std::abs(int(b) - int(c)), pb = std::abs(int(a) - int(c)), pc = std::abs(int(a) + int(b) - 2 * int(c));
  const unsigned b_or_c = pb <= pc ? b : c;
  return (pa <= pb && pa <= pc) ? a : b_or_c;
}

/// Undoes one row's filter for 2-byte pixels; `up` is the previous row, unfiltered (zeros above
/// the first). Returns false on a filter type the specification does not define.
bool unfilterRow(int filter, std::uint8_t* cur, const std::uint8_t* up, std::size_t n) {
  switch (filter) {
    case 0: return true;
    case 1:
      for (std::size_t i = 2; i < n; ++i) cur[i] = std::uint8_t(cur[i] + cur[i - 2]);
      return true;
    case 2:
      for (std::size_t i = 0; i < n; ++i) cur[i] = std::uint8_t(cur[i] + up[i]);
      return true;
    case 3:
      for (std::size_t i = 0; i < 2; ++i) cur[i] = std::uint8_t(cur[i] + (up[i] >> 1));
      for (std::size_t i = 2; i < n; ++i) cur[i] = std::uint8_t(cur[i] + ((unsigned(cur[i - 2]) + up[i]) >> 1));
      return true;
    case 4: {
      // The first pixel has no left neighbours: the predictor is the byte above. Then the pixel's
      // two bytes are two independent chains, run side by side.
      for (std::size_t i = 0; i < 2; ++i) cur[i] = std::uint8_t(cur[i] + up[i]);
      unsigned a0 = cur[0], a1 = cur[1];
      for (std::size_t i = 2; i < n; i += 2) {
        a0 = std::uint8_t(cur[i] + paeth(a0, up[i], up[i - 2]));
        a1 = std::uint8_t(cur[i + 1] + paeth(a1, up[i + 1], up[i - 1]));
        cur[i] = std::uint8_t(a0);
        cur[i + 1] = std::uint8_t(a1);
      }
      return true;
    }
    default: return false;
  }
}

struct DecompressorDeleter {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

}  // namespace

bool decodeGray16Png(const std::uint8_t* file, std::size_t size, std::uint32_t max_side, std::uint32_t& width,
                     std::uint32_t& height, std::vector<std::uint16_t>& samples) {
  if (size < 8 + 25 || std::memcmp(file, kSignature, 8) != 0) return false;
  // The chunks: IHDR first, then any ancillary chunks, one run of IDATs and IEND.
  std::vector<std::pair<const std::uint8_t*, std::size_t>> idat;
  bool idat_ended = false, header = false, end = false;
  std::size_t pos = 8;
  while (!end) {
    if (size - pos < 12) return false;
    const std::uint32_t length = be32(file + pos);
    const std::uint8_t* type = file + pos + 4;
    if (length > kMaxChunkLength || length > size - pos - 12) return false;
    const std::uint8_t* data = type + 4;
    for (int i = 0; i < 4; ++i)
      if (!isLetter(type[i])) return false;
    if (std::uint32_t(libdeflate_crc32(0, type, 4 + std::size_t(length))) != be32(data + length)) return false;
    const bool is_idat = std::memcmp(type, "IDAT", 4) == 0;
    if (!header) {
      // Width and height in [1, max_side]; bit depth 16, colour type 0 (gray), compression,
      // filter method 0, no interlace.
      if (std::memcmp(type, "IHDR", 4) != 0 || length != 13) return false;
      width = be32(data);
      height = be32(data + 4);
      if (width == 0 || height == 0 || width > max_side || height > max_side) return false;
      if (data[8] != 16 || data[9] != 0 || data[10] != 0 || data[11] != 0 || data[12] != 0) return false;
      header = true;
    } else if (is_idat) {
      if (idat_ended) return false;  // IDATs must be consecutive
      idat.emplace_back(data, length);
    } else {
      if (!idat.empty()) idat_ended = true;
      end = std::memcmp(type, "IEND", 4) == 0;
      if (end && length != 0) return false;
      // Any other critical chunk (upper-case first letter: IHDR again, PLTE, unknown) is declined.
      if (!end && !(type[0] & 0x20)) return false;
    }
    pos += 12 + std::size_t(length);
  }
  if (idat.empty()) return false;

  std::vector<std::uint8_t> joined;
  const std::uint8_t* stream = idat[0].first;
  std::size_t stream_size = idat[0].second;
  if (idat.size() > 1) {
    for (const auto& [data, length] : idat) joined.insert(joined.end(), data, data + length);
    stream = joined.data();
    stream_size = joined.size();
  }
  // Each row: a filter byte, then 2 bytes per pixel, big-endian.
  const std::size_t row_bytes = 2 * std::size_t(width), rows_size = std::size_t(height) * (1 + row_bytes);
  std::vector<std::uint8_t> rows(rows_size);
  const std::unique_ptr<libdeflate_decompressor, DecompressorDeleter> inflater(libdeflate_alloc_decompressor());
  if (!inflater) return false;
  std::size_t used_in = 0, made = 0;
  if (libdeflate_zlib_decompress_ex(inflater.get(), stream, stream_size, rows.data(), rows_size, &used_in, &made) !=
          LIBDEFLATE_SUCCESS ||
      made != rows_size || used_in != stream_size)
    return false;

  const std::vector<std::uint8_t> zeros(row_bytes, 0);
  samples.resize(std::size_t(width) * height);
  for (std::size_t y = 0; y < height; ++y) {
    std::uint8_t* row = rows.data() + y * (1 + row_bytes);
    const std::uint8_t* up = y > 0 ? row - row_bytes : zeros.data();
    if (!unfilterRow(row[0], row + 1, up, row_bytes)) return false;
    std::uint16_t* out = samples.data() + y * width;
    for (std::size_t x = 0; x < width; ++x) out[x] = std::uint16_t((unsigned(row[1 + 2 * x]) << 8) | row[2 + 2 * x]);
  }
  return true;
}

}  // namespace vdbmap::io::internal
