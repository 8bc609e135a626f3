// The fast 16-bit gray PNG decoder (vdbmap/io/src/png_gray16.hpp) against the samples libpng was
// given to write, for every filter type, sizes from one pixel up and image data split over many
// IDAT chunks; against libpng's decoding of real Kinect frames; and its declining of every file it
// is not sure of, which readDepthPng then decodes or refuses through libpng as before.
#include "test_io_helpers.hpp"

#include "png_gray16.hpp"
#include "vdbmap/io/png_io.hpp"

#include <png.h>
#include <zlib.h>

#include <cstdio>
#include <cstring>
#include <random>

using vdbmap::io::internal::decodeGray16Png;
using vdbmap::test::TempDir;

namespace {

std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | p[3];
}

/// Writes a 16-bit gray PNG with libpng: `filter` one of libpng's PNG_FILTER_* masks (one type, or
/// several for its adaptive choice per row), IDAT chunks of at most `idat_bytes` bytes.
std::vector<std::uint8_t> encodeGray16(int width, int height, const std::vector<std::uint16_t>& samples, int filter,
                                       std::size_t idat_bytes, int interlace = PNG_INTERLACE_NONE) {
  std::vector<std::uint8_t> out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  REQUIRE((png && info));
  if (setjmp(png_jmpbuf(png))) FAIL("libpng failed to write the test image");
  png_set_write_fn(
      png, &out,
      [](png_structp p, png_bytep data, png_size_t n) {
        auto* o = static_cast<std::vector<std::uint8_t>*>(png_get_io_ptr(p));
        o->insert(o->end(), data, data + n);
      },
      nullptr);
  png_set_compression_buffer_size(png, idat_bytes);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, filter);
  png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), 16, PNG_COLOR_TYPE_GRAY, interlace,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  std::vector<std::uint8_t> big_endian(samples.size() * 2);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    big_endian[2 * i] = std::uint8_t(samples[i] >> 8);
    big_endian[2 * i + 1] = std::uint8_t(samples[i] & 0xff);
  }
  std::vector<png_bytep> rows(static_cast<std::size_t>(height));
  for (int y = 0; y < height; ++y) rows[std::size_t(y)] = big_endian.data() + std::size_t(y) * std::size_t(width) * 2;
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

/// Depth-like samples: a smooth ramp with steps, noise and holes (0), so that every filter has
/// varied neighbours, and Paeth picks each of its three predictors.
std::vector<std::uint16_t> depthLike(int width, int height, std::mt19937& rng) {
  std::vector<std::uint16_t> s(std::size_t(width) * std::size_t(height));
  std::uniform_int_distribution<int> noise(-40, 40), hole(0, 19), any(0, 65535);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      int v = 800 + 7 * x + 3 * y + ((x / 5 + y / 3) % 2) * 900 + noise(rng);
      if (hole(rng) == 0) v = 0;
      if (hole(rng) == 1) v = any(rng);
      s[std::size_t(y) * std::size_t(width) + std::size_t(x)] = std::uint16_t(std::clamp(v, 0, 65535));
    }
  return s;
}

/// Chunk offsets of a PNG: (offset of the length field, type).
std::vector<std::pair<std::size_t, std::string>> chunksOf(const std::vector<std::uint8_t>& png) {
  std::vector<std::pair<std::size_t, std::string>> chunks;
  for (std::size_t pos = 8; pos + 12 <= png.size(); pos += 12 + be32(png.data() + pos))
    chunks.emplace_back(pos, std::string(reinterpret_cast<const char*>(png.data() + pos + 4), 4));
  return chunks;
}

/// Recomputes the CRC of the chunk at `pos` after an edit of its type or data.
void fixCrc(std::vector<std::uint8_t>& png, std::size_t pos) {
  const std::uint32_t length = be32(png.data() + pos);
  const std::uint32_t crc = std::uint32_t(::crc32(0, png.data() + pos + 4, length + 4));
  for (int i = 0; i < 4; ++i) png[pos + 8 + length + std::size_t(i)] = std::uint8_t(crc >> (24 - 8 * i));
}

/// Inserts a chunk of `type` and `data` before the byte at `pos`.
void insertChunk(std::vector<std::uint8_t>& png, std::size_t pos, const std::string& type, const std::string& data) {
  std::vector<std::uint8_t> chunk(12 + data.size(), 0);
  const std::uint32_t n = std::uint32_t(data.size());
  for (int i = 0; i < 4; ++i) chunk[std::size_t(i)] = std::uint8_t(n >> (24 - 8 * i));
  std::memcpy(chunk.data() + 4, type.data(), 4);
  std::memcpy(chunk.data() + 8, data.data(), data.size());
  png.insert(png.begin() + std::ptrdiff_t(pos), chunk.begin(), chunk.end());
  fixCrc(png, pos);
}

bool decodes(const std::vector<std::uint8_t>& png) {
  std::uint32_t w = 0, h = 0;
  std::vector<std::uint16_t> s;
  return decodeGray16Png(png.data(), png.size(), 16384, w, h, s);
}

}  // namespace

TEST_CASE("The fast decoder gives the samples libpng wrote, for every filter and chunking", "[io][png]") {
  std::mt19937 rng(5);
  const std::vector<std::pair<int, const char*>> filters = {{PNG_FILTER_NONE, "none"},   {PNG_FILTER_SUB, "sub"},
                                                            {PNG_FILTER_UP, "up"},       {PNG_FILTER_AVG, "average"},
                                                            {PNG_FILTER_PAETH, "paeth"}, {PNG_ALL_FILTERS, "adaptive"}};
  const std::vector<std::pair<int, int>> sizes = {{1, 1}, {1, 7}, {2, 1}, {3, 2}, {17, 5}, {64, 48}, {641, 13}};
  for (const auto& [filter, name] : filters)
    for (const auto& [width, height] : sizes)
      for (const std::size_t idat : {std::size_t(8192), std::size_t(37)}) {
        INFO(name << " filter, " << width << "x" << height << ", IDATs of " << idat << " bytes");
        const std::vector<std::uint16_t> samples = depthLike(width, height, rng);
        const std::vector<std::uint8_t> png = encodeGray16(width, height, samples, filter, idat);
        std::uint32_t w = 0, h = 0;
        std::vector<std::uint16_t> back;
        REQUIRE(decodeGray16Png(png.data(), png.size(), 16384, w, h, back));
        CHECK(w == std::uint32_t(width));
        CHECK(h == std::uint32_t(height));
        CHECK(back == samples);
      }
}

TEST_CASE("The fast decoder agrees with libpng on real Kinect depth frames", "[io][png][shared_data]") {
  const auto dir = vdbmap::test::sharedData("7scenes_redkitchen_tsdf_fusion_python/depth");
  int checked = 0;
  for (int k = 0; k < 1000 && checked < 25; k += 40) {
    char name[64];
    std::snprintf(name, sizeof(name), "frame-%06d.depth.png", k);
    const auto path = dir / name;
    if (!std::filesystem::exists(path)) continue;
    const std::string text = vdbmap::test::readBytes(path);
    const std::vector<std::uint8_t> bytes(text.begin(), text.end());
    std::uint32_t w = 0, h = 0;
    std::vector<std::uint16_t> fast;
    INFO(path);
    REQUIRE(decodeGray16Png(bytes.data(), bytes.size(), 16384, w, h, fast));
    const vdbmap::io::PngImage reference = vdbmap::io::readPng(path);  // libpng
    CHECK(int(w) == reference.width);
    CHECK(int(h) == reference.height);
    CHECK(fast == reference.samples);
    ++checked;
  }
  CHECK(checked >= 10);
}

TEST_CASE("The fast decoder declines what it is not sure of, and readDepthPng still reads or refuses it", "[io][png]") {
  std::mt19937 rng(6);
  const int width = 23, height = 9;
  const std::vector<std::uint16_t> samples = depthLike(width, height, rng);
  const std::vector<std::uint8_t> good = encodeGray16(width, height, samples, PNG_ALL_FILTERS, 64);
  REQUIRE(decodes(good));
  const auto chunks = chunksOf(good);
  const auto find = [&](const std::string& type) {
    for (const auto& [pos, t] : chunks)
      if (t == type) return pos;
    FAIL("no " << type << " chunk");
    return std::size_t(0);
  };
  const std::size_t ihdr = find("IHDR"), idat = find("IDAT"), iend = find("IEND");
  TempDir dir;
  const auto readBack = [&](const std::vector<std::uint8_t>& png, const std::string& name) {
    vdbmap::test::writeText(dir / name, std::string(png.begin(), png.end()));
    return vdbmap::io::readDepthPng(dir / name, 0.001);
  };

  SECTION("an interlaced image: libpng decodes it") {
    const std::vector<std::uint8_t> png =
        encodeGray16(width, height, samples, PNG_ALL_FILTERS, 8192, PNG_INTERLACE_ADAM7);
    CHECK_FALSE(decodes(png));
    // The same depth as the same samples read through the fast path.
    CHECK(readBack(png, "adam7.png").depth_m == readBack(good, "plain.png").depth_m);
  }
  SECTION("an 8-bit image: refused as the wrong kind") {
    std::vector<std::uint8_t> png = good;
    png[ihdr + 8 + 8] = 8;
    fixCrc(png, ihdr);
    CHECK_FALSE(decodes(png));
    VDBMAP_REQUIRE_THROWS_MENTIONING(readBack(png, "eight.png"), "16-bit");
  }
  SECTION("a wrong CRC in the image data: refused by libpng") {
    std::vector<std::uint8_t> png = good;
    png[idat + 8] ^= 0x40;
    CHECK_FALSE(decodes(png));
    VDBMAP_REQUIRE_THROWS_MENTIONING(readBack(png, "crc.png"), "crc.png");
  }
  SECTION("a wrong CRC in IEND") {
    std::vector<std::uint8_t> png = good;
    png[iend + 8] ^= 1;
    CHECK_FALSE(decodes(png));
  }
  SECTION("truncated anywhere") {
    for (std::size_t keep = 0; keep < good.size(); keep += 7) {
      INFO("first " << keep << " bytes");
      CHECK_FALSE(decodes(std::vector<std::uint8_t>(good.begin(), good.begin() + std::ptrdiff_t(keep))));
    }
  }
  SECTION("a chunk length beyond the file") {
    std::vector<std::uint8_t> png = good;
    png[idat] = 0x7f;
    CHECK_FALSE(decodes(png));
  }
  SECTION("a palette chunk, a second IHDR, an unknown critical chunk") {
    for (const std::string type : {"PLTE", "IHDR", "ZZZZ"}) {
      std::vector<std::uint8_t> png = good;
      insertChunk(png, idat, type, std::string(type == "IHDR" ? 13 : 3, '\0'));
      INFO(type);
      CHECK_FALSE(decodes(png));
    }
  }
  SECTION("an ancillary chunk before the image data is skipped; one between IDATs is not") {
    std::vector<std::uint8_t> png = good;
    insertChunk(png, idat, "tEXt", std::string("Comment\0depth", 13));
    CHECK(decodes(png));
    const auto split = chunksOf(good);
    std::size_t second_idat = 0;
    for (std::size_t i = 1; i < split.size(); ++i)
      if (split[i].second == "IDAT" && split[i - 1].second == "IDAT") second_idat = split[i].first;
    REQUIRE(second_idat > 0);
    png = good;
    insertChunk(png, second_idat, "tEXt", std::string("Comment\0x", 9));
    CHECK_FALSE(decodes(png));
  }
  SECTION("a filter type beyond 4, and bytes after the zlib stream") {
    // The rows as written: a filter byte (0, none) and the big-endian samples.
    std::vector<std::uint8_t> rows;
    for (int y = 0; y < height; ++y) {
      rows.push_back(0);
      for (int x = 0; x < width; ++x) {
        const std::uint16_t v = samples[std::size_t(y * width + x)];
        rows.push_back(std::uint8_t(v >> 8));
        rows.push_back(std::uint8_t(v & 0xff));
      }
    }
    const auto makePng = [&](const std::vector<std::uint8_t>& image_rows, std::size_t trailing) {
      uLongf n = compressBound(uLong(image_rows.size()));
      std::vector<std::uint8_t> stream(n);
      REQUIRE(compress(stream.data(), &n, image_rows.data(), uLong(image_rows.size())) == Z_OK);
      stream.resize(n + trailing, 0);
      std::vector<std::uint8_t> png(good.begin(), good.begin() + std::ptrdiff_t(ihdr + 25));  // signature, IHDR
      insertChunk(png, png.size(), "IDAT", std::string(stream.begin(), stream.end()));
      insertChunk(png, png.size(), "IEND", "");
      return png;
    };
    std::uint32_t w = 0, h = 0;
    std::vector<std::uint16_t> back;
    const std::vector<std::uint8_t> plain = makePng(rows, 0);
    REQUIRE(decodeGray16Png(plain.data(), plain.size(), 16384, w, h, back));
    CHECK(back == samples);
    CHECK_FALSE(decodes(makePng(rows, 1)));
    std::vector<std::uint8_t> bad_filter = rows;
    bad_filter[std::size_t(3 * (1 + 2 * width))] = 5;  // row 3
    const std::vector<std::uint8_t> png = makePng(bad_filter, 0);
    CHECK_FALSE(decodes(png));
    VDBMAP_REQUIRE_THROWS_MENTIONING(readBack(png, "filter5.png"), "filter5.png");
  }
  SECTION("a header beyond the side limit") {
    std::uint32_t w = 0, h = 0;
    std::vector<std::uint16_t> s;
    CHECK_FALSE(decodeGray16Png(good.data(), good.size(), std::uint32_t(width - 1), w, h, s));
  }
}
