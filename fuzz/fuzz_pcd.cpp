// Fuzz target: PCD point clouds (ascii, binary, binary_compressed) through io::readPointCloud.
#include "fuzz_support.hpp"

#include "vdbmap/io/point_cloud_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace vdbmap;
  const std::filesystem::path file = fuzz::freshScratchDir() / "input.pcd";
  fuzz::writeFile(file, data, size);
  fuzz::expectRefusalOrSuccess([&] { io::readPointCloud(file); });
  return 0;
}
