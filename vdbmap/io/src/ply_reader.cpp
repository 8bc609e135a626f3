#include "ply_reader.hpp"

#include "text_util.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

namespace vdbmap::io::detail {
namespace {

enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };
enum class PlyFormat { Ascii, BinaryLittleEndian, BinaryBigEndian };

struct PlyProperty {
  std::string name;
  bool is_list = false;
  PlyType count_type = PlyType::UInt8;
  PlyType type = PlyType::Float32;
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
};

bool parseType(std::string_view s, PlyType& t) {
  if (s == "char" || s == "int8") t = PlyType::Int8;
  else if (s == "uchar" || s == "uint8") t = PlyType::UInt8;
  else if (s == "short" || s == "int16") t = PlyType::Int16;
  else if (s == "ushort" || s == "uint16") t = PlyType::UInt16;
  else if (s == "int" || s == "int32") t = PlyType::Int32;
  else if (s == "uint" || s == "uint32") t = PlyType::UInt32;
  else if (s == "float" || s == "float32") t = PlyType::Float32;
  else if (s == "double" || s == "float64") t = PlyType::Float64;
  else return false;
  return true;
}

std::size_t typeSize(PlyType t) {
  switch (t) {
    case PlyType::Int8: case PlyType::UInt8: return 1;
    case PlyType::Int16: case PlyType::UInt16: return 2;
    case PlyType::Int32: case PlyType::UInt32: case PlyType::Float32: return 4;
    case PlyType::Float64: return 8;
  }
  return 0;
}

bool isIntegral(PlyType t) { return t != PlyType::Float32 && t != PlyType::Float64; }

// Reads one binary scalar at `p` as a double; `swap` reverses the byte order (big endian data
// on a little-endian host).
inline double decodeScalar(const unsigned char* p, PlyType t, bool swap) {
  unsigned char b[8];
  const std::size_t n = typeSize(t);
  if (swap) {
    for (std::size_t i = 0; i < n; ++i) b[i] = p[n - 1 - i];
  } else {
    std::memcpy(b, p, n);
  }
  switch (t) {
    case PlyType::Int8: { std::int8_t v; std::memcpy(&v, b, 1); return v; }
    case PlyType::UInt8: return b[0];
    case PlyType::Int16: { std::int16_t v; std::memcpy(&v, b, 2); return v; }
    case PlyType::UInt16: { std::uint16_t v; std::memcpy(&v, b, 2); return v; }
    case PlyType::Int32: { std::int32_t v; std::memcpy(&v, b, 4); return v; }
    case PlyType::UInt32: { std::uint32_t v; std::memcpy(&v, b, 4); return v; }
    case PlyType::Float32: { float v; std::memcpy(&v, b, 4); return v; }
    case PlyType::Float64: { double v; std::memcpy(&v, b, 8); return v; }
  }
  return 0.0;
}

bool hostIsLittleEndian() {
  const std::uint16_t one = 1;
  unsigned char c;
  std::memcpy(&c, &one, 1);
  return c == 1;
}

// Fans a polygon (v0, v1, ..., vn-1) into triangles (v0, vi, vi+1).
void fan(const std::vector<std::int64_t>& poly, std::vector<Eigen::Vector3i>& out) {
  for (std::size_t i = 1; i + 1 < poly.size(); ++i)
    out.emplace_back(int(poly[0]), int(poly[i]), int(poly[i + 1]));
}

// Refuses, naming the file, the element and its declared count, element counts that the bytes
// after the header cannot hold, before anything is reserved (a 200-byte header claiming 1e12
// vertices must not allocate). Lower bounds per instance: binary, its fixed-size properties plus
// the count of each list (lists may be empty); ascii, one character and a separator per value (a
// list at least its count). The binary reader still checks each instance as it goes.
void checkCounts(const std::filesystem::path& path, const std::vector<PlyElement>& elements, bool ascii,
                 std::size_t bytes_left) {
  const std::size_t avail = ascii ? bytes_left + 1 : bytes_left;  // the last ascii value needs no separator
  std::size_t need = 0;
  for (const PlyElement& e : elements) {
    std::size_t per = 0;
    for (const PlyProperty& p : e.properties) per += ascii ? 2 : typeSize(p.is_list ? p.count_type : p.type);
    if (per == 0 || e.count == 0) continue;
    if (e.count > (avail - need) / per)
      fail(path, "truncated or corrupt: element '" + e.name + "' declares count " + std::to_string(e.count) +
                     " (at least " + std::to_string(per) + " bytes each" + (ascii ? " as ascii" : "") +
                     "), more than the " + std::to_string(bytes_left) + " bytes after the header can hold");
    need += e.count * per;
  }
}

}  // namespace

PlyContent readPly(const std::filesystem::path& path, bool read_faces) {
  const std::string data = readWholeFile(path);
  LineReader lines(data);
  std::string_view line;
  std::vector<std::string_view> tok;

  if (!lines.next(line) || trim(line) != "ply") failAt(path, 1, "not a PLY file (the first line must be 'ply')");
  PlyFormat format = PlyFormat::Ascii;
  bool have_format = false;
  std::vector<PlyElement> elements;
  bool ended = false;
  while (lines.next(line)) {
    splitWhitespace(line, tok);
    if (tok.empty() || tok[0] == "comment" || tok[0] == "obj_info") continue;
    const std::size_t ln = lines.lineNumber();
    if (tok[0] == "format") {
      if (tok.size() != 3) failAt(path, ln, "expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'");
      if (tok[1] == "ascii") format = PlyFormat::Ascii;
      else if (tok[1] == "binary_little_endian") format = PlyFormat::BinaryLittleEndian;
      else if (tok[1] == "binary_big_endian") format = PlyFormat::BinaryBigEndian;
      else failAt(path, ln, "unknown PLY format " + quoteToken(tok[1]));
      have_format = true;
    } else if (tok[0] == "element") {
      std::int64_t count = 0;
      if (tok.size() != 3 || !parseInt64(tok[2], count) || count < 0)
        failAt(path, ln, "expected 'element <name> <count>'");
      elements.push_back({std::string(tok[1]), std::size_t(count), {}});
    } else if (tok[0] == "property") {
      if (elements.empty()) failAt(path, ln, "property before any element");
      PlyProperty prop;
      if (tok.size() == 5 && tok[1] == "list") {
        prop.is_list = true;
        if (!parseType(tok[2], prop.count_type) || !parseType(tok[3], prop.type))
          failAt(path, ln, "unknown type in list property");
        if (!isIntegral(prop.count_type)) failAt(path, ln, "a list count must have an integer type");
        prop.name = std::string(tok[4]);
      } else if (tok.size() == 3) {
        if (!parseType(tok[1], prop.type)) failAt(path, ln, "unknown property type " + quoteToken(tok[1]));
        prop.name = std::string(tok[2]);
      } else {
        failAt(path, ln, "expected 'property <type> <name>' or 'property list <count type> <type> <name>'");
      }
      elements.back().properties.push_back(prop);
    } else if (tok[0] == "end_header") {
      ended = true;
      break;
    } else {
      failAt(path, ln, "unknown header keyword " + quoteToken(tok[0]));
    }
  }
  if (!ended) fail(path, "PLY header has no 'end_header' line (truncated file?)");
  if (!have_format) fail(path, "PLY header has no 'format' line");
  checkCounts(path, elements, format == PlyFormat::Ascii, data.size() - lines.offset());

  PlyContent content;
  const PlyElement* vertex_el = nullptr;
  for (const PlyElement& e : elements)
    if (e.name == "vertex") vertex_el = &e;
  int ix = -1, iy = -1, iz = -1;
  if (vertex_el) {
    for (std::size_t p = 0; p < vertex_el->properties.size(); ++p) {
      const PlyProperty& prop = vertex_el->properties[p];
      if (prop.is_list) continue;
      if (prop.name == "x") ix = int(p);
      if (prop.name == "y") iy = int(p);
      if (prop.name == "z") iz = int(p);
    }
    if (ix < 0 || iy < 0 || iz < 0) fail(path, "element 'vertex' lacks one of the properties x, y, z");
    content.vertices.reserve(vertex_el->count);
  }

  std::vector<std::int64_t> poly;
  const auto isFaceList = [](const PlyElement& e, const PlyProperty& p) {
    return e.name == "face" && p.is_list && (p.name == "vertex_indices" || p.name == "vertex_index");
  };

  if (format == PlyFormat::Ascii) {
    for (const PlyElement& e : elements) {
      const bool is_vertex = &e == vertex_el;
      for (std::size_t k = 0; k < e.count; ++k) {
        bool got = false;
        while (lines.next(line)) {
          splitWhitespace(line, tok);
          if (!tok.empty()) { got = true; break; }
        }
        const std::size_t ln = lines.lineNumber();
        if (!got)
          fail(path, "truncated: expected " + std::to_string(e.count) + " '" + e.name + "' lines, the file ends after " +
                         std::to_string(k));
        std::size_t t = 0;
        Vec3f xyz(0.f, 0.f, 0.f);
        auto need = [&](std::size_t n) {
          if (t + n > tok.size())
            failAt(path, ln, "element '" + e.name + "' has too few values on this line (" + std::to_string(tok.size()) + ")");
        };
        for (std::size_t p = 0; p < e.properties.size(); ++p) {
          const PlyProperty& prop = e.properties[p];
          if (!prop.is_list) {
            need(1);
            double v;
            if (!parseDouble(tok[t], v)) failAt(path, ln, "property '" + prop.name + "' is not a number: " + quoteToken(tok[t]));
            ++t;
            if (is_vertex) {
              if (int(p) == ix) xyz.x() = float(v);
              if (int(p) == iy) xyz.y() = float(v);
              if (int(p) == iz) xyz.z() = float(v);
            }
          } else {
            need(1);
            std::int64_t n;
            if (!parseInt64(tok[t], n) || n < 0) failAt(path, ln, "bad list length " + quoteToken(tok[t]));
            ++t;
            need(std::size_t(n));
            const bool face = read_faces && isFaceList(e, prop);
            if (face) poly.clear();
            for (std::int64_t i = 0; i < n; ++i, ++t) {
              double v;
              if (!parseDouble(tok[t], v)) failAt(path, ln, "list '" + prop.name + "' holds a non-number " + quoteToken(tok[t]));
              if (face) {
                std::int64_t idx;
                if (!parseInt64(tok[t], idx)) failAt(path, ln, "vertex index " + quoteToken(tok[t]) + " is not an integer");
                poly.push_back(idx);
              }
            }
            if (face) {
              if (poly.size() < 3) failAt(path, ln, "face with " + std::to_string(poly.size()) + " vertices (need >= 3)");
              for (std::int64_t idx : poly)
                if (idx < 0 || (vertex_el && std::size_t(idx) >= vertex_el->count))
                  failAt(path, ln, "face refers to vertex " + std::to_string(idx) + " but there are " +
                                       std::to_string(vertex_el ? vertex_el->count : 0) + " vertices");
              fan(poly, content.triangles);
            }
          }
        }
        if (t != tok.size())
          failAt(path, ln, "element '" + e.name + "' has " + std::to_string(tok.size()) + " values on this line, expected " +
                               std::to_string(t));
        if (is_vertex) content.vertices.push_back(xyz);
        if (e.name == "face") ++content.face_count;
      }
    }
    return content;
  }

  const bool swap = (format == PlyFormat::BinaryBigEndian) == hostIsLittleEndian();
  const auto* base = reinterpret_cast<const unsigned char*>(data.data());
  std::size_t pos = lines.offset();
  const std::size_t size = data.size();
  for (const PlyElement& e : elements) {
    const bool is_vertex = &e == vertex_el;
    if (e.properties.empty()) {  // instances of no bytes: nothing to read, however many are declared
      if (e.name == "face") content.face_count += e.count;
      continue;
    }
    for (std::size_t k = 0; k < e.count; ++k) {
      Vec3f xyz(0.f, 0.f, 0.f);
      auto truncated = [&]() {
        fail(path, "truncated: element '" + e.name + "' number " + std::to_string(k) + " of " + std::to_string(e.count) +
                       " runs past the end of the file (" + std::to_string(size) + " bytes)");
      };
      for (std::size_t p = 0; p < e.properties.size(); ++p) {
        const PlyProperty& prop = e.properties[p];
        if (!prop.is_list) {
          const std::size_t n = typeSize(prop.type);
          if (pos + n > size) truncated();
          if (is_vertex && (int(p) == ix || int(p) == iy || int(p) == iz)) {
            const double v = decodeScalar(base + pos, prop.type, swap);
            if (int(p) == ix) xyz.x() = float(v);
            if (int(p) == iy) xyz.y() = float(v);
            if (int(p) == iz) xyz.z() = float(v);
          }
          pos += n;
        } else {
          const std::size_t cn = typeSize(prop.count_type);
          if (pos + cn > size) truncated();
          const double count_d = decodeScalar(base + pos, prop.count_type, swap);
          pos += cn;
          if (count_d < 0) fail(path, "element '" + e.name + "' number " + std::to_string(k) + " has a negative list length");
          const std::size_t n = std::size_t(count_d);
          const std::size_t in = typeSize(prop.type);
          if (pos + n * in > size) truncated();
          if (read_faces && isFaceList(e, prop)) {
            if (n < 3) fail(path, "face number " + std::to_string(k) + " has " + std::to_string(n) + " vertices (need >= 3)");
            poly.clear();
            const std::size_t vertices = vertex_el ? vertex_el->count : 0;
            for (std::size_t i = 0; i < n; ++i) {
              const double v = decodeScalar(base + pos + i * in, prop.type, swap);
              // Checked as a double before any conversion: a float index may be 1e30, NaN or 2.5,
              // and converting an out-of-range double to an integer is undefined behaviour.
              if (!(v >= 0.0 && v < double(vertices)) || v != std::floor(v))
                fail(path, "face number " + std::to_string(k) + " refers to vertex " + std::to_string(v) +
                               " but there are " + std::to_string(vertices) + " vertices");
              poly.push_back(static_cast<std::int64_t>(v));
            }
            fan(poly, content.triangles);
          }
          pos += n * in;
        }
      }
      if (is_vertex) content.vertices.push_back(xyz);
      if (e.name == "face") ++content.face_count;
    }
  }
  return content;
}

}  // namespace vdbmap::io::detail
