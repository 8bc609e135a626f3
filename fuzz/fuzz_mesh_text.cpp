// Fuzz target: the text mesh formats OBJ and OFF through io::readTriangleMesh. The same bytes are
// read as both (each refuses the other's files at once), so one corpus serves the two readers.
#include "fuzz_support.hpp"

#include "vdbmap/io/mesh_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace vdbmap;
  const std::filesystem::path dir = fuzz::freshScratchDir();
  for (const char* name : {"input.obj", "input.off"}) {
    fuzz::writeFile(dir / name, data, size);
    fuzz::expectRefusalOrSuccess([&] { io::readTriangleMesh(dir / name); });
  }
  return 0;
}
