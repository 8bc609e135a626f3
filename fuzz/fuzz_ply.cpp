// Fuzz target: PLY (vdbmap/io/src/ply_reader.cpp), as a mesh (faces fanned and checked) and as a
// point cloud (vertices only), both through the public readers.
#include "fuzz_support.hpp"

#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/io/point_cloud_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace vdbmap;
  const std::filesystem::path file = fuzz::freshScratchDir() / "input.ply";
  fuzz::writeFile(file, data, size);
  fuzz::expectRefusalOrSuccess([&] { io::readTriangleMesh(file); });
  fuzz::expectRefusalOrSuccess([&] { io::readPointCloud(file); });
  return 0;
}
