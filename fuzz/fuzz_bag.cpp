// Fuzz target: ROS1 bags (vdbmap/io/ros_bag.hpp) through Debian's rosbag_storage: the bytes as a
// .bag, listed by io::inspectRosBag, opened by io::openRosBag (topics picked when unambiguous)
// and every depth frame loaded. Built only with bag support (VDBMAP_HAS_ROSBAG).
#include "fuzz_support.hpp"

#include "vdbmap/io/ros_bag.hpp"

#include <memory>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace vdbmap;
  const std::filesystem::path file = fuzz::freshScratchDir() / "input.bag";
  fuzz::writeFile(file, data, size);
  fuzz::expectRefusalOrSuccess([&] { io::inspectRosBag(file); });
  fuzz::expectRefusalOrSuccess([&] {
    const std::unique_ptr<io::FrameSource> source = io::openRosBag(file);
    for (std::size_t i = 0; i < source->size(); ++i) fuzz::expectRefusalOrSuccess([&] { source->load(i); });
  });
  return 0;
}
