#include "vdbmap/io/point_cloud_io.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/io/errors.hpp"

#include "ply_reader.hpp"
#include "text_util.hpp"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

namespace vdbmap::io {
namespace {

using detail::fail;
using detail::failAt;
using detail::quoteToken;

std::string lowerExtension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

bool hostIsLittleEndian() {
  const std::uint16_t one = 1;
  unsigned char c;
  std::memcpy(&c, &one, 1);
  return c == 1;
}

// Largest COUNT of one PCD field (PCL's widest descriptors hold a few hundred values); keeps the
// record size far from overflowing.
constexpr std::int64_t kMaxPcdFieldCount = std::int64_t{1} << 20;
// Largest output of LZF per input byte: a 3-byte back-reference copies at most 264 bytes.
constexpr std::size_t kLzfMaxRatio = 88;

struct PcdField {
  std::string name;
  std::size_t size = 4;
  char type = 'F';  // F float, I signed, U unsigned
  std::size_t count = 1;
  std::size_t offset = 0;  // byte offset inside a point record (binary)
  std::size_t column = 0;  // first column (ascii)
};

// PCD values are little endian (PCL writes host order; every platform it targets is little endian).
double decodePcd(const unsigned char* p, const PcdField& f) {
  unsigned char b[8] = {0};
  std::memcpy(b, p, f.size);
  if (!hostIsLittleEndian()) std::reverse(b, b + f.size);
  if (f.type == 'F') {
    if (f.size == 4) { float v; std::memcpy(&v, b, 4); return v; }
    double v; std::memcpy(&v, b, 8); return v;
  }
  if (f.type == 'I') {
    switch (f.size) {
      case 1: { std::int8_t v; std::memcpy(&v, b, 1); return v; }
      case 2: { std::int16_t v; std::memcpy(&v, b, 2); return v; }
      case 4: { std::int32_t v; std::memcpy(&v, b, 4); return v; }
      default: { std::int64_t v; std::memcpy(&v, b, 8); return double(v); }
    }
  }
  switch (f.size) {
    case 1: return b[0];
    case 2: { std::uint16_t v; std::memcpy(&v, b, 2); return v; }
    case 4: { std::uint32_t v; std::memcpy(&v, b, 4); return v; }
    default: { std::uint64_t v; std::memcpy(&v, b, 8); return double(v); }
  }
}

// LZF decompression (the format PCL's binary_compressed uses): a control byte below 32 starts a
// run of ctrl+1 literal bytes; otherwise its top 3 bits are a length (7 = read one more byte),
// its low 5 bits and the next byte an offset back into the output. Returns false on bad input.
bool lzfDecompress(const unsigned char* in, std::size_t in_size, unsigned char* out, std::size_t out_size) {
  std::size_t ip = 0, op = 0;
  while (ip < in_size) {
    const unsigned ctrl = in[ip++];
    if (ctrl < 32) {
      const std::size_t len = ctrl + 1;
      if (ip + len > in_size || op + len > out_size) return false;
      std::memcpy(out + op, in + ip, len);
      ip += len;
      op += len;
    } else {
      std::size_t len = ctrl >> 5;
      if (len == 7) {
        if (ip >= in_size) return false;
        len += in[ip++];
      }
      if (ip >= in_size) return false;
      const std::size_t back = ((std::size_t(ctrl & 0x1f) << 8) | in[ip++]) + 1;
      len += 2;
      if (back > op || op + len > out_size) return false;
      for (std::size_t k = 0; k < len; ++k, ++op) out[op] = out[op - back];  // may overlap
    }
  }
  return op == out_size;
}

PointCloud readPcd(const std::filesystem::path& path) {
  const std::string data = detail::readWholeFile(path);
  detail::LineReader lines(data);
  std::string_view line;
  std::vector<std::string_view> tok;
  std::vector<PcdField> fields;
  std::vector<std::string_view> sizes, types, counts;
  std::size_t sizes_line = 0, types_line = 0, counts_line = 0;
  std::int64_t width = -1, height = 1, points = -1;
  std::string data_kind;
  while (lines.next(line)) {
    const std::size_t hash = line.find('#');
    if (hash != std::string_view::npos) line = line.substr(0, hash);
    detail::splitWhitespace(line, tok);
    if (tok.empty()) continue;
    const std::size_t ln = lines.lineNumber();
    const std::string_view key = tok[0];
    auto oneInt = [&](std::int64_t& v) {
      if (tok.size() != 2 || !detail::parseInt64(tok[1], v) || v < 0) failAt(path, ln, "expected '" + std::string(key) + " <count>'");
    };
    if (key == "VERSION" || key == "VIEWPOINT") {
      continue;
    } else if (key == "FIELDS" || key == "COLUMNS") {
      fields.clear();
      for (std::size_t i = 1; i < tok.size(); ++i) fields.push_back({std::string(tok[i])});
    } else if (key == "SIZE") {
      sizes.assign(tok.begin() + 1, tok.end());
      sizes_line = ln;
    } else if (key == "TYPE") {
      types.assign(tok.begin() + 1, tok.end());
      types_line = ln;
    } else if (key == "COUNT") {
      counts.assign(tok.begin() + 1, tok.end());
      counts_line = ln;
    } else if (key == "WIDTH") {
      oneInt(width);
    } else if (key == "HEIGHT") {
      oneInt(height);
    } else if (key == "POINTS") {
      oneInt(points);
    } else if (key == "DATA") {
      if (tok.size() != 2) failAt(path, ln, "expected 'DATA ascii|binary|binary_compressed'");
      data_kind = std::string(tok[1]);
      if (data_kind != "ascii" && data_kind != "binary" && data_kind != "binary_compressed")
        failAt(path, ln, "unknown PCD data kind " + quoteToken(tok[1]));
      break;
    } else {
      failAt(path, ln, "unknown PCD header keyword " + quoteToken(key));
    }
  }
  if (data_kind.empty()) fail(path, "PCD header has no DATA line (not a PCD file, or truncated)");
  if (fields.empty()) fail(path, "PCD header has no FIELDS line");
  if (sizes.size() != fields.size()) failAt(path, sizes_line, "SIZE must list one size per field");
  if (types.size() != fields.size()) failAt(path, types_line, "TYPE must list one type per field");
  if (!counts.empty() && counts.size() != fields.size()) failAt(path, counts_line, "COUNT must list one count per field");
  std::size_t record = 0, columns = 0;
  int ix = -1, iy = -1, iz = -1;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    PcdField& f = fields[i];
    std::int64_t s = 0, c = 1;
    if (!detail::parseInt64(sizes[i], s) || (s != 1 && s != 2 && s != 4 && s != 8)) failAt(path, sizes_line, "bad SIZE " + quoteToken(sizes[i]));
    if (types[i].size() != 1 || std::string_view("FIU").find(types[i][0]) == std::string_view::npos)
      failAt(path, types_line, "bad TYPE " + quoteToken(types[i]));
    if (!counts.empty() && (!detail::parseInt64(counts[i], c) || c < 1 || c > kMaxPcdFieldCount))
      failAt(path, counts_line,
             "bad COUNT " + quoteToken(counts[i]) + " (1 to " + std::to_string(kMaxPcdFieldCount) + ")");
    f.size = std::size_t(s);
    f.type = types[i][0];
    if (f.type == 'F' && f.size != 4 && f.size != 8) failAt(path, types_line, "float field '" + f.name + "' must have SIZE 4 or 8");
    f.count = std::size_t(c);
    f.offset = record;
    f.column = columns;
    record += f.size * f.count;
    columns += f.count;
    if (f.name == "x") ix = int(i);
    if (f.name == "y") iy = int(i);
    if (f.name == "z") iz = int(i);
  }
  if (ix < 0 || iy < 0 || iz < 0) fail(path, "PCD has no x, y and z fields");
  std::string points_field = "POINTS";
  if (points < 0) {
    if (width < 0) fail(path, "PCD header has neither POINTS nor WIDTH");
    if (height > 0 && width > std::numeric_limits<std::int64_t>::max() / height)
      fail(path, "WIDTH " + std::to_string(width) + " x HEIGHT " + std::to_string(height) + " overflows");
    points = width * height;
    points_field = "WIDTH x HEIGHT";
  }
  const std::size_t n = std::size_t(points);
  const PcdField& fx = fields[std::size_t(ix)];
  const PcdField& fy = fields[std::size_t(iy)];
  const PcdField& fz = fields[std::size_t(iz)];
  const std::size_t body_size = data.size() - lines.offset();
  // Every count is checked against the bytes after the header before the cloud is reserved.
  const auto tooMany = [&](const std::string& per_point) {
    fail(path, "truncated or corrupt: " + points_field + " declares " + std::to_string(n) + " points (" + per_point +
                   "), more than the " + std::to_string(body_size) + " bytes after the header can hold");
  };
  PointCloud cloud;

  if (data_kind == "ascii") {
    // At least one character and a separator per value (the last value needs no separator): a
    // count the body cannot hold reserves nothing, and the parse below names the line where the
    // values run out.
    if (n <= (body_size + 1) / (2 * columns)) cloud.reserve(n);
    for (std::size_t k = 0; k < n; ++k) {
      bool got = false;
      while (lines.next(line)) {
        detail::splitWhitespace(line, tok);
        if (!tok.empty()) { got = true; break; }
      }
      if (!got)
        fail(path, "truncated: " + points_field + " declares " + std::to_string(n) + " points but the file ends after " +
                       std::to_string(k));
      const std::size_t ln = lines.lineNumber();
      if (tok.size() != columns)
        failAt(path, ln, "expected " + std::to_string(columns) + " values, found " + std::to_string(tok.size()));
      double v[3];
      const PcdField* xyz[3] = {&fx, &fy, &fz};
      for (int a = 0; a < 3; ++a)
        if (!detail::parseDouble(tok[xyz[a]->column], v[a]))
          failAt(path, ln, "field '" + xyz[a]->name + "' is not a number: " + quoteToken(tok[xyz[a]->column]));
      cloud.emplace_back(float(v[0]), float(v[1]), float(v[2]));
    }
    return cloud;
  }

  const auto* body = reinterpret_cast<const unsigned char*>(data.data()) + lines.offset();
  if (data_kind == "binary") {
    if (n > body_size / record) tooMany(std::to_string(record) + " bytes each");
    cloud.reserve(n);
    for (std::size_t k = 0; k < n; ++k) {
      const unsigned char* p = body + k * record;
      cloud.emplace_back(float(decodePcd(p + fx.offset, fx)), float(decodePcd(p + fy.offset, fy)),
                         float(decodePcd(p + fz.offset, fz)));
    }
    return cloud;
  }
  // binary_compressed: uint32 compressed size, uint32 uncompressed size, LZF data; the
  // uncompressed data hold each field for all points in turn (structure of arrays).
  if (body_size < 8) fail(path, "truncated: binary_compressed data lack their size header");
  std::uint32_t csize = 0, usize = 0;
  std::memcpy(&csize, body, 4);
  std::memcpy(&usize, body + 4, 4);
  if (std::size_t(csize) + 8 > body_size)
    fail(path, "truncated: compressed data of " + std::to_string(csize) + " bytes, the file has " + std::to_string(body_size - 8));
  if (n > std::size_t(usize) / record || std::size_t(usize) != n * record)
    fail(path, "binary_compressed size " + std::to_string(usize) + " does not match " + points_field + " = " +
                   std::to_string(n) + " points of " + std::to_string(record) + " bytes");
  if (std::size_t(usize) > kLzfMaxRatio * std::size_t(csize))
    fail(path, "corrupt: binary_compressed data of " + std::to_string(csize) + " bytes cannot expand to " +
                   std::to_string(usize) + " bytes (LZF expands at most " + std::to_string(kLzfMaxRatio) + "x)");
  std::vector<unsigned char> raw(usize);
  cloud.reserve(n);
  if (usize > 0 && !lzfDecompress(body + 8, csize, raw.data(), usize)) fail(path, "corrupt LZF data in binary_compressed PCD");
  auto soa = [&](const PcdField& f, std::size_t k) {
    return decodePcd(raw.data() + f.offset * n + k * f.size * f.count, f);
  };
  for (std::size_t k = 0; k < n; ++k) cloud.emplace_back(float(soa(fx, k)), float(soa(fy, k)), float(soa(fz, k)));
  return cloud;
}

PointCloud readBin(const std::filesystem::path& path) {
  const std::string data = detail::readWholeFile(path);
  constexpr std::size_t kRecord = 3 * sizeof(float);
  if (data.size() % kRecord != 0)
    fail(path, "raw float32 xyz file size " + std::to_string(data.size()) + " is not a multiple of 12 bytes (truncated?)");
  PointCloud cloud(data.size() / kRecord);
  const bool swap = !hostIsLittleEndian();
  for (std::size_t k = 0; k < cloud.size(); ++k) {
    for (int a = 0; a < 3; ++a) {
      unsigned char b[4];
      std::memcpy(b, data.data() + k * kRecord + std::size_t(a) * 4, 4);
      if (swap) std::reverse(b, b + 4);
      std::memcpy(&cloud[k][a], b, 4);
    }
  }
  return cloud;
}

void writeFloats(std::ostream& out, const PointCloud& points) {
  // Vec3f is 3 packed floats; the project only targets little-endian hosts for binary output.
  if (!hostIsLittleEndian()) throw std::runtime_error("binary point-cloud writing needs a little-endian host");
  for (const Vec3f& p : points) out.write(reinterpret_cast<const char*>(p.data()), 3 * sizeof(float));
}

}  // namespace

PointCloud readPointCloud(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw FileError(path.string() + ": no such file");
  const std::string ext = lowerExtension(path);
  if (ext == ".ply") return detail::readPly(path, /*read_faces=*/false).vertices;
  if (ext == ".pcd") return readPcd(path);
  if (ext == ".bin") return readBin(path);
  fail(path, "unknown point-cloud extension '" + ext + "' (expected .ply, .pcd or .bin)");
}

void writePointCloud(const std::filesystem::path& path, const PointCloud& points) {
  const std::string ext = lowerExtension(path);
  if (ext != ".ply" && ext != ".pcd" && ext != ".bin")
    throw std::invalid_argument("writePointCloud: unknown extension '" + ext + "' of " + path.string() +
                                " (expected .ply, .pcd or .bin)");
  writeFileAtomically(path, [&](std::ostream& out) {
    if (ext == ".ply") {
      out << "ply\nformat binary_little_endian 1.0\ncomment written by vdbmap\nelement vertex " << points.size()
          << "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    } else if (ext == ".pcd") {
      out << "# .PCD v0.7 - written by vdbmap\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH "
          << points.size() << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << points.size() << "\nDATA binary\n";
    }
    writeFloats(out, points);
  });
}

}  // namespace vdbmap::io
