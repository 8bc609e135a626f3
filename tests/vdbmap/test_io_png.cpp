// PNG through libpng: 16-bit depth round trip, 8/16-bit gray/RGB(A) round trip, reading the
// shared datasets' depth (values cross-checked with an independent decoder), and rejection of
// corrupt, truncated and wrong-kind files with the file named.
#include "test_io_helpers.hpp"

#include "vdbmap/io/png_io.hpp"

#include <cmath>
#include <random>

using vdbmap::DepthImage;
using vdbmap::io::PngImage;
using vdbmap::test::readBytes;
using vdbmap::test::sharedData;
using vdbmap::test::TempDir;
using vdbmap::test::writeText;

TEST_CASE("16-bit depth PNG round trip is exact up to the depth unit", "[io][png]") {
  TempDir dir;
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> z(0.2f, 8.0f);
  DepthImage d(64, 48);
  for (float& v : d.depth_m) v = z(rng);
  d.at(0, 0) = 0.0f;
  d.at(1, 0) = std::nanf("");
  d.at(2, 0) = -1.0f;
  d.at(3, 0) = 70.0f;  // > 65535 mm: does not fit
  const double scale = 0.001;
  std::size_t clipped = 0;
  vdbmap::io::writeDepthPng(dir / "d.png", d, scale, &clipped);
  CHECK(clipped == 1);
  const DepthImage back = vdbmap::io::readDepthPng(dir / "d.png", scale);
  REQUIRE(back.width == 64);
  REQUIRE(back.height == 48);
  for (int u = 0; u < 4; ++u) CHECK(back.at(u, 0) == 0.0f);
  double max_err = 0.0;
  for (std::size_t i = 4; i < d.depth_m.size(); ++i) max_err = std::max(max_err, std::abs(double(back.depth_m[i]) - d.depth_m[i]));
  CHECK(max_err <= 0.5 * scale + 1e-6);  // rounding to the nearest unit
  // Writing the read-back image again gives identical values (the quantisation is idempotent).
  vdbmap::io::writeDepthPng(dir / "d2.png", back, scale);
  CHECK(vdbmap::io::readDepthPng(dir / "d2.png", scale).depth_m == back.depth_m);
  int w = 0, h = 0;
  vdbmap::io::readPngSize(dir / "d.png", w, h);
  CHECK((w == 64 && h == 48));
}

TEST_CASE("PNG round trip for gray, gray+alpha, RGB and RGBA at 8 and 16 bits", "[io][png]") {
  TempDir dir;
  std::mt19937 rng(7);
  for (int bits : {8, 16}) {
    for (int channels = 1; channels <= 4; ++channels) {
      PngImage img;
      img.width = 13;
      img.height = 5;
      img.channels = channels;
      img.bit_depth = bits;
      std::uniform_int_distribution<int> s(0, (1 << bits) - 1);
      img.samples.resize(std::size_t(13 * 5 * channels));
      for (auto& v : img.samples) v = std::uint16_t(s(rng));
      const auto path = dir / ("img" + std::to_string(bits) + "_" + std::to_string(channels) + ".png");
      vdbmap::io::writePng(path, img);
      const PngImage back = vdbmap::io::readPng(path);
      INFO(bits << " bits, " << channels << " channels");
      CHECK(back.bit_depth == bits);
      CHECK(back.channels == channels);
      CHECK(back.samples == img.samples);
    }
  }
}

TEST_CASE("Depth PNGs of the shared datasets decode to the reference values", "[io][png][shared]") {
  // Reference raw values from an independent Python decoder (zlib + PNG filters).
  struct Ref {
    const char* file;
    int w, h;
    std::uint16_t at_320_240, at_100_50;
  };
  const Ref refs[] = {
      {"7scenes_redkitchen_tsdf_fusion_python/depth/frame-000000.depth.png", 640, 480, 1382, 0},
      {"iclnuim_livingroom_5frames_slambook2/depth/1.png", 640, 480, 16890, 12180},
      {"open3d_testdata_redwood_tum/RGBD/depth/00000.png", 640, 480, 2195, 1364},
      {"open3d_testdata_redwood_tum/RGBD/other_formats/TUM_depth.png", 640, 480, 10920, 10515},
      {"nvblox_testdata/3dmatch/seq-01/frame-000000.depth.png", 640, 480, 2485, 6497},
      {"nvblox_testdata/replica/office0/results/depth000000.png", 1200, 680, 15126, 10819},
  };
  for (const Ref& r : refs) {
    INFO(r.file);
    const PngImage raw = vdbmap::io::readPng(sharedData(r.file));
    REQUIRE(raw.width == r.w);
    REQUIRE(raw.height == r.h);
    REQUIRE(raw.channels == 1);
    REQUIRE(raw.bit_depth == 16);
    CHECK(raw.at(320, 240) == r.at_320_240);
    CHECK(raw.at(100, 50) == r.at_100_50);
    const DepthImage d = vdbmap::io::readDepthPng(sharedData(r.file), 0.001);
    CHECK(d.at(320, 240) == Approx(r.at_320_240 * 0.001).epsilon(1e-6));
  }
  // nvblox's own unit test: 3DMatch frame 0 has max depth 7.835 m.
  const DepthImage d = vdbmap::io::readDepthPng(sharedData("nvblox_testdata/3dmatch/seq-01/frame-000000.depth.png"), 0.001);
  CHECK(*std::max_element(d.depth_m.begin(), d.depth_m.end()) == Approx(7.835f));
}

TEST_CASE("Corrupt, truncated and wrong-kind PNGs are rejected naming the file", "[io][png][bad-input]") {
  TempDir dir;
  DepthImage d(40, 30, 1.5f);
  for (int i = 0; i < 40 * 30; ++i) d.depth_m[std::size_t(i)] = 0.5f + 0.001f * float(i);
  vdbmap::io::writeDepthPng(dir / "good.png", d, 0.001);
  const std::string bytes = readBytes(dir / "good.png");

  SECTION("missing") {
    VDBMAP_REQUIRE_THROWS_MENTIONING(vdbmap::io::readDepthPng(dir / "none.png", 0.001), "none.png", "no such file");
  }
  SECTION("not a PNG") {
    writeText(dir / "text.png", "hello, I am not a PNG at all");
    VDBMAP_REQUIRE_THROWS_MENTIONING(vdbmap::io::readDepthPng(dir / "text.png", 0.001), "text.png", "not a PNG");
  }
  SECTION("truncated in the image data") {
    writeText(dir / "cut.png", bytes.substr(0, bytes.size() / 2));
    VDBMAP_REQUIRE_THROWS_MENTIONING(vdbmap::io::readDepthPng(dir / "cut.png", 0.001), "cut.png", "truncated");
    VDBMAP_REQUIRE_THROWS_MENTIONING(vdbmap::io::readPng(dir / "cut.png"), "cut.png");
  }
  SECTION("truncated after the image data (no IEND)") {
    writeText(dir / "noend.png", bytes.substr(0, bytes.size() - 12));
    VDBMAP_REQUIRE_THROWS_MENTIONING(vdbmap::io::readDepthPng(dir / "noend.png", 0.001), "noend.png");
  }
  SECTION("a flipped byte in the compressed data") {
    std::string bad = bytes;
    const std::size_t idat = bad.find("IDAT");
    REQUIRE(idat != std::string::npos);
    bad[idat + 10] = char(bad[idat + 10] ^ 0x5a);
    writeText(dir / "crc.png", bad);
    VDBMAP_REQUIRE_THROWS_MENTIONING(vdbmap::io::readDepthPng(dir / "crc.png", 0.001), "crc.png", "corrupt");
  }
  SECTION("an 8-bit RGB image where depth is expected") {
    VDBMAP_REQUIRE_THROWS_MENTIONING(
        vdbmap::io::readDepthPng(sharedData("iclnuim_livingroom_5frames_slambook2/color/1.png"), 0.001), "color/1.png",
        "16-bit gray", "8-bit RGB");
  }
}
