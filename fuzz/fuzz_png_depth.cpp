// Fuzz target: PNG depth images (vdbmap/io/png_io.hpp). The bytes are written to a .png and read
// as a 16-bit depth image (unchecked size, and against a camera of the input's own header size),
// then as any PNG, and their header alone. Whatever the fast 16-bit gray decoder accepts, libpng
// must decode to the same samples.
#include "fuzz_support.hpp"

#include "png_gray16.hpp"
#include "vdbmap/io/png_io.hpp"

#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace vdbmap;
  const std::filesystem::path file = fuzz::freshScratchDir() / "depth.png";
  fuzz::writeFile(file, data, size);
  int width = 0, height = 0;
  fuzz::expectRefusalOrSuccess([&] { io::readPngSize(file, width, height); });
  fuzz::expectRefusalOrSuccess([&] { io::readDepthPng(file, 0.001); });
  // 7-Scenes' invalid value, and the camera check with the header's own size (so decoding runs).
  fuzz::expectRefusalOrSuccess([&] { io::readDepthPng(file, 1.0 / 5000.0, 65535, width, height); });
  fuzz::expectRefusalOrSuccess([&] { io::readPng(file); });
  std::uint32_t fast_width = 0, fast_height = 0;
  std::vector<std::uint16_t> fast;
  if (io::internal::decodeGray16Png(data, size, std::uint32_t(io::kMaxPngSide), fast_width, fast_height, fast)) {
    const io::PngImage reference = io::readPng(file);  // must not throw: the file is a valid PNG
    if (reference.width != int(fast_width) || reference.height != int(fast_height) || reference.samples != fast)
      std::abort();  // the fast decoder and libpng disagree
  }
  return 0;
}
