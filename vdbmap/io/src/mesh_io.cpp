#include "vdbmap/io/mesh_io.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/io/errors.hpp"

#include "ply_reader.hpp"
#include "text_util.hpp"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>

namespace vdbmap::io {
namespace {

using detail::failAt;
using detail::fail;
using detail::quoteToken;

std::string lowerExtension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

void checkIndices(const std::filesystem::path& path, const TriangleMesh& mesh) {
  const auto n = static_cast<long long>(mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (mesh.triangles[i][k] < 0 || mesh.triangles[i][k] >= n)
        fail(path, "triangle " + std::to_string(i) + " refers to vertex " + std::to_string(mesh.triangles[i][k]) +
                       " but there are " + std::to_string(n) + " vertices");
}

// Wavefront OBJ: 'v x y z [w]' and 'f a b c ...' where each corner is 'i', 'i/t', 'i//n' or
// 'i/t/n', 1-based, negative = relative to the vertices read so far. Everything else (normals,
// texture coordinates, groups, materials, lines) is ignored.
TriangleMesh readObj(const std::filesystem::path& path) {
  const std::string text = detail::readWholeFile(path);
  detail::LineReader lines(text);
  std::string_view line;
  std::vector<std::string_view> tok;
  std::vector<std::int64_t> poly;
  std::vector<std::size_t> face_lines;  // the line of each triangle, for index errors
  TriangleMesh mesh;
  while (lines.next(line)) {
    const std::size_t hash = line.find('#');
    if (hash != std::string_view::npos) line = line.substr(0, hash);
    detail::splitWhitespace(line, tok);
    if (tok.empty()) continue;
    const std::size_t ln = lines.lineNumber();
    if (tok[0] == "v") {
      if (tok.size() < 4) failAt(path, ln, "vertex needs 3 coordinates");
      double xyz[3];
      for (int k = 0; k < 3; ++k)
        if (!detail::parseDouble(tok[1 + k], xyz[k])) failAt(path, ln, "vertex coordinate " + quoteToken(tok[1 + k]) + " is not a number");
      mesh.vertices.emplace_back(float(xyz[0]), float(xyz[1]), float(xyz[2]));
    } else if (tok[0] == "f") {
      if (tok.size() < 4) failAt(path, ln, "face with " + std::to_string(tok.size() - 1) + " vertices (need >= 3)");
      poly.clear();
      for (std::size_t k = 1; k < tok.size(); ++k) {
        std::string_view corner = tok[k];
        corner = corner.substr(0, corner.find('/'));
        std::int64_t idx;
        if (!detail::parseInt64(corner, idx) || idx == 0) failAt(path, ln, "bad face index " + quoteToken(tok[k]));
        // 1-based; negative counts back from the last vertex read so far.
        idx = idx > 0 ? idx - 1 : std::int64_t(mesh.vertices.size()) + idx;
        if (idx < 0) failAt(path, ln, "relative face index " + quoteToken(tok[k]) + " points before the first vertex");
        if (idx > INT32_MAX) failAt(path, ln, "face index " + quoteToken(tok[k]) + " is too large");
        poly.push_back(idx);
      }
      for (std::size_t i = 1; i + 1 < poly.size(); ++i) {
        mesh.triangles.emplace_back(int(poly[0]), int(poly[i]), int(poly[i + 1]));
        face_lines.push_back(ln);
      }
    }
  }
  const auto n = static_cast<long long>(mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (mesh.triangles[i][k] >= n)
        failAt(path, face_lines[i], "face refers to vertex " + std::to_string(mesh.triangles[i][k] + 1) + " (1-based) but the file has " +
                                        std::to_string(n) + " vertices");
  return mesh;
}

// Object File Format: a header 'OFF' (also COFF, NOFF, CNOFF, STOFF...), the counts
// 'vertices faces edges' (on the header line or the next), one vertex per line (extra values
// such as colours ignored), then 'n i0 ... in-1 [colour]' per face. '#' starts a comment.
TriangleMesh readOff(const std::filesystem::path& path) {
  const std::string text = detail::readWholeFile(path);
  detail::LineReader lines(text);
  std::string_view line;
  std::vector<std::string_view> tok;
  auto nextTokens = [&]() -> bool {
    while (lines.next(line)) {
      const std::size_t hash = line.find('#');
      if (hash != std::string_view::npos) line = line.substr(0, hash);
      detail::splitWhitespace(line, tok);
      if (!tok.empty()) return true;
    }
    return false;
  };
  if (!nextTokens()) fail(path, "empty file, expected an OFF header");
  const std::string_view magic = tok[0];
  if (magic.size() < 3 || magic.substr(magic.size() - 3) != "OFF" || magic.find_first_of("4n") != std::string_view::npos)
    failAt(path, lines.lineNumber(), "not an OFF file (header " + quoteToken(magic) + ")");
  std::vector<std::string_view> counts(tok.begin() + 1, tok.end());
  if (counts.empty()) {
    if (!nextTokens()) fail(path, "truncated: no vertex/face counts after the header");
    counts = tok;
  }
  std::int64_t nv = 0, nf = 0;
  if (counts.size() < 2 || !detail::parseInt64(counts[0], nv) || !detail::parseInt64(counts[1], nf) || nv < 0 || nf < 0)
    failAt(path, lines.lineNumber(), "expected '<vertices> <faces> <edges>'");
  // The counts must fit in the bytes after them before anything is reserved: a vertex line holds at
  // least 3 values, a face line at least 4, each value a character and a separator (the last value
  // of the file needs none).
  const std::size_t avail = text.size() - lines.offset() + 1;
  if (std::uint64_t(nv) > avail / 6)
    failAt(path, lines.lineNumber(), "truncated or corrupt: the header declares " + std::to_string(nv) +
                                         " vertices (at least 6 bytes each), more than the " +
                                         std::to_string(avail - 1) + " bytes after it can hold");
  if (std::uint64_t(nf) > (avail - std::size_t(nv) * 6) / 8)
    failAt(path, lines.lineNumber(), "truncated or corrupt: the header declares " + std::to_string(nv) +
                                         " vertices and " + std::to_string(nf) +
                                         " faces (at least 8 bytes each), more than the " +
                                         std::to_string(avail - 1) + " bytes after it can hold");
  TriangleMesh mesh;
  mesh.vertices.reserve(std::size_t(nv));
  mesh.triangles.reserve(std::size_t(nf));
  for (std::int64_t i = 0; i < nv; ++i) {
    if (!nextTokens())
      fail(path, "truncated: expected " + std::to_string(nv) + " vertices, the file ends after " + std::to_string(i));
    const std::size_t ln = lines.lineNumber();
    if (tok.size() < 3) failAt(path, ln, "vertex needs 3 coordinates");
    double xyz[3];
    for (int k = 0; k < 3; ++k)
      if (!detail::parseDouble(tok[k], xyz[k])) failAt(path, ln, "vertex coordinate " + quoteToken(tok[k]) + " is not a number");
    mesh.vertices.emplace_back(float(xyz[0]), float(xyz[1]), float(xyz[2]));
  }
  for (std::int64_t i = 0; i < nf; ++i) {
    if (!nextTokens()) fail(path, "truncated: expected " + std::to_string(nf) + " faces, the file ends after " + std::to_string(i));
    const std::size_t ln = lines.lineNumber();
    std::int64_t n = 0;
    if (!detail::parseInt64(tok[0], n) || n < 3) failAt(path, ln, "face needs a vertex count >= 3, got " + quoteToken(tok[0]));
    // n > size - 1, not size < n + 1: n comes from the file and may be INT64_MAX (no overflow).
    if (n > std::int64_t(tok.size()) - 1)
      failAt(path, ln, "face lists " + std::to_string(tok.size() - 1) + " indices, expected " + std::to_string(n));
    std::int64_t idx[3];
    auto index = [&](std::int64_t k) {
      std::int64_t v;
      if (!detail::parseInt64(tok[std::size_t(k + 1)], v)) failAt(path, ln, "bad vertex index " + quoteToken(tok[std::size_t(k + 1)]));
      if (v < 0 || v >= nv) failAt(path, ln, "face refers to vertex " + std::to_string(v) + " but there are " + std::to_string(nv) + " vertices");
      return v;
    };
    idx[0] = index(0);
    idx[1] = index(1);
    for (std::int64_t k = 2; k < n; ++k) {
      idx[2] = index(k);
      mesh.triangles.emplace_back(int(idx[0]), int(idx[1]), int(idx[2]));
      idx[1] = idx[2];
    }
  }
  return mesh;
}

}  // namespace

TriangleMesh readTriangleMesh(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw FileError(path.string() + ": no such file");
  const std::string ext = lowerExtension(path);
  TriangleMesh mesh;
  if (ext == ".ply") {
    detail::PlyContent ply = detail::readPly(path, /*read_faces=*/true);
    mesh.vertices = std::move(ply.vertices);
    mesh.triangles = std::move(ply.triangles);
  } else if (ext == ".obj") {
    mesh = readObj(path);
  } else if (ext == ".off") {
    mesh = readOff(path);
  } else {
    fail(path, "unknown mesh extension '" + ext + "' (expected .ply, .obj or .off)");
  }
  checkIndices(path, mesh);
  return mesh;
}

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
