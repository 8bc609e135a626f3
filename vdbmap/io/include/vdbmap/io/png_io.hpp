// PNG images through libpng: 16-bit depth images (read and write) and 8/16-bit gray, gray+alpha,
// RGB and RGBA images (read and write). Plain 16-bit gray depth PNGs are read by a faster decoder
// of the library's own (libdeflate's inflate); every other file, and every error, goes to libpng.
#pragma once

#include "vdbmap/camera.hpp"

#include <cstdint>
#include <filesystem>
#include <vector>

namespace vdbmap::io {

/// Largest width and height the PNG readers accept (and the writers write). The readers check the
/// header before decoding: a larger image, or one whose header declares more pixel data than the
/// file could hold compressed (deflate expands at most 1032:1), is refused with a FileError naming
/// the file, so a tiny hostile file cannot make them allocate gigabytes.
inline constexpr int kMaxPngSide = 16384;

/// A decoded PNG: `channels` interleaved samples per pixel (1 gray, 2 gray+alpha, 3 RGB,
/// 4 RGBA), row-major, each sample in [0, 2^bit_depth - 1]. Palette images and gray images of
/// fewer than 8 bits are expanded to 8-bit RGB(A) / gray; transparency chunks become alpha.
struct PngImage {
  int width = 0;
  int height = 0;
  int channels = 0;   ///< 1..4
  int bit_depth = 0;  ///< 8 or 16
  std::vector<std::uint16_t> samples;  ///< size width * height * channels

  std::uint16_t at(int u, int v, int c = 0) const {
    return samples[(std::size_t(v) * std::size_t(width) + std::size_t(u)) * std::size_t(channels) + std::size_t(c)];
  }
};

/// Reads any PNG. Throws std::runtime_error naming the file on a missing, corrupt or truncated
/// file (libpng's own diagnosis is included, e.g. "IDAT: CRC error" or "Read Error"), and on a
/// header beyond the limits of kMaxPngSide.
PngImage readPng(const std::filesystem::path& path);

/// Width and height from the PNG header only (no decoding). Throws std::runtime_error naming the
/// file when it is missing, too short or not a PNG, or its header is beyond the limits of kMaxPngSide.
void readPngSize(const std::filesystem::path& path, int& width, int& height);

/// Writes `image` (bit_depth 8 or 16, channels 1..4, sides at most kMaxPngSide) to a temporary
/// file beside `path` and renames it over `path`. Throws std::invalid_argument on an inconsistent
/// image and std::runtime_error naming the file when writing fails.
void writePng(const std::filesystem::path& path, const PngImage& image);

/// Reads a 16-bit single-channel depth PNG into metres: depth_m = value * depth_scale
/// (depth_scale = metres per unit, e.g. 0.001 for millimetres). Raw 0 (and `invalid_raw` when
/// non-zero, e.g. 65535 in 7-Scenes) becomes 0 = invalid. Throws std::runtime_error naming the
/// file when the PNG is not 16-bit gray, is corrupt or truncated, or is beyond the limits of
/// kMaxPngSide.
DepthImage readDepthPng(const std::filesystem::path& path, double depth_scale, std::uint16_t invalid_raw = 0);

/// As above for a camera's frame: a header size other than expected_width x expected_height is
/// refused before decoding, with a FileError naming the file and both sizes.
DepthImage readDepthPng(const std::filesystem::path& path, double depth_scale, std::uint16_t invalid_raw,
                        int expected_width, int expected_height);

/// Writes depth in metres as a 16-bit gray PNG with value = round(depth_m / depth_scale). Pixels
/// that are invalid (0, NaN, negative, infinite) or that do not fit (value > 65535) are written
/// as 0; `clipped_count`, when given, receives the number of finite positive depths written as 0
/// because they were too large. Atomic like writePng; sides at most kMaxPngSide.
void writeDepthPng(const std::filesystem::path& path, const DepthImage& depth, double depth_scale,
                   std::size_t* clipped_count = nullptr);

}  // namespace vdbmap::io
