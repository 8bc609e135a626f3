#include "vdbmap/io/mesh_io.hpp"

#include "vdbmap/io/atomic_file.hpp"

#include <cstdint>
#include <fstream>
#include <stdexcept>

namespace vdbmap::io {

void writePlyMesh(const std::filesystem::path& path, const TriangleMesh& mesh) {
  writeFileAtomically(path, [&](std::ostream& out) {
    out << "ply\nformat binary_little_endian 1.0\ncomment written by vdbmap\n"
        << "element vertex " << mesh.vertices.size() << "\n"
        << "property float x\nproperty float y\nproperty float z\n"
        << "element face " << mesh.triangles.size() << "\n"
        << "property list uchar int vertex_indices\nend_header\n";
    for (const Vec3f& v : mesh.vertices) out.write(reinterpret_cast<const char*>(v.data()), 3 * sizeof(float));
    for (const Eigen::Vector3i& t : mesh.triangles) {
      const std::uint8_t n = 3;
      out.write(reinterpret_cast<const char*>(&n), 1);
      const std::int32_t idx[3] = {t[0], t[1], t[2]};
      out.write(reinterpret_cast<const char*>(idx), sizeof(idx));
    }
  });
}

}  // namespace vdbmap::io
