// Conversions between numpy arrays and the library's types, with clear ValueErrors, and the
// registry of the module's parts.
#include "binding.hpp"

#include <algorithm>
#include <cstring>
#include <limits>
#include <sstream>
#include <tuple>
#include <vector>

namespace vdbmap::python {

// ---- the registry of parts ------------------------------------------------------------------------

namespace {
struct Part {
  int order;
  std::string name;
  BindFunction bind;
};
std::vector<Part>& parts() {
  static std::vector<Part> registered;
  return registered;
}
}  // namespace

BindRegistration::BindRegistration(int order, const char* name, BindFunction bind) {
  parts().push_back({order, name, bind});
}

void bindAllParts(py::module_& m) {
  std::vector<Part> sorted = parts();
  std::sort(sorted.begin(), sorted.end(),
            [](const Part& a, const Part& b) { return std::tie(a.order, a.name) < std::tie(b.order, b.name); });
  for (const Part& p : sorted) p.bind(m);
}

py::module_ submodule(py::module_& parent, const char* name, const char* doc) {
  py::module_ sub = parent.def_submodule(name, doc);
  py::module_::import("sys").attr("modules")[py::str(sub.attr("__name__"))] = sub;
  return sub;
}

// ---- describing what was received -----------------------------------------------------------------

namespace {

std::string shapeText(const py::array& a) {
  std::ostringstream s;
  s << "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) s << (d ? ", " : "") << a.shape(d) << (a.ndim() == 1 ? "," : "");
  s << ")";
  return s.str();
}

std::string received(const py::array& a) {
  return "got an array of shape " + shapeText(a) + " and dtype " + std::string(py::str(a.dtype()));
}

[[noreturn]] void fail(const char* arg, const std::string& expected, const py::array& a) {
  throw py::value_error(std::string(arg) + ": expected " + expected + ", " + received(a));
}

/// The argument as an ndarray: arrays as they are, anything else through numpy.asarray with
/// `fallback_dtype` (nested lists), or a ValueError naming the argument.
py::array asArray(py::handle obj, const char* arg, const char* expected, const char* fallback_dtype) {
  if (py::isinstance<py::array>(obj)) return py::reinterpret_borrow<py::array>(obj);
  try {
    return py::module_::import("numpy").attr("asarray")(obj, fallback_dtype);
  } catch (py::error_already_set&) {
    throw py::value_error(std::string(arg) + ": expected " + expected + ", got " +
                          std::string(py::str(py::type::of(obj).attr("__name__"))) + " that numpy cannot read as one");
  }
}

bool isFloat(const py::array& a) {
  const char kind = a.dtype().kind();
  return kind == 'f' && (a.itemsize() == 4 || a.itemsize() == 8);
}
bool isInteger(const py::array& a) {
  const char kind = a.dtype().kind();
  return kind == 'i' || kind == 'u';
}

/// A C-contiguous copy (or view) of `a` as T.
template <typename T>
py::array_t<T, py::array::c_style | py::array::forcecast> contiguous(const py::array& a) {
  return py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(a);
}

}  // namespace

// ---- numpy -> C++ ---------------------------------------------------------------------------------

PointCloud toPoints(py::handle points, const char* arg) {
  constexpr const char* expected = "an (N, 3) array of float32 or float64";
  const py::array a = asArray(points, arg, expected, "float64");
  if (!isFloat(a) || a.ndim() != 2 || a.shape(1) != 3) fail(arg, expected, a);
  const auto f = contiguous<float>(a);
  const float* p = f.data();
  PointCloud out(std::size_t(f.shape(0)));
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = Vec3f(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
  return out;
}

Pose3d toPose(py::handle T, const char* arg) {
  constexpr const char* expected = "a (4, 4) array of float32 or float64";
  const py::array a = asArray(T, arg, expected, "float64");
  if (!isFloat(a) || a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4) fail(arg, expected, a);
  const auto d = contiguous<double>(a);
  const auto m = d.unchecked<2>();
  if (m(3, 0) != 0.0 || m(3, 1) != 0.0 || m(3, 2) != 0.0 || m(3, 3) != 1.0) {
    std::ostringstream s;
    s << arg << ": the last row of a pose must be [0, 0, 0, 1], got [" << m(3, 0) << ", " << m(3, 1) << ", " << m(3, 2)
      << ", " << m(3, 3) << "]";
    throw py::value_error(s.str());
  }
  Pose3d pose = Pose3d::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) pose.matrix()(r, c) = m(r, c);
  return pose;
}

Vec3d toVec3(py::handle v, const char* arg) {
  constexpr const char* expected = "a (3,) array of float32 or float64";
  const py::array a = asArray(v, arg, expected, "float64");
  if (!isFloat(a) || a.ndim() != 1 || a.shape(0) != 3) fail(arg, expected, a);
  const auto d = contiguous<double>(a);
  return {d.at(0), d.at(1), d.at(2)};
}

DepthImage toDepth(py::handle depth, const std::optional<double>& depth_scale, const char* arg) {
  constexpr const char* expected = "an (H, W) array of float32 or float64 (metres) or uint16 (with depth_scale)";
  const py::array a = asArray(depth, arg, expected, "float64");
  const bool raw = a.dtype().kind() == 'u' && a.itemsize() == 2;
  if ((!raw && !isFloat(a)) || a.ndim() != 2) fail(arg, expected, a);
  const int height = int(a.shape(0)), width = int(a.shape(1));
  if (raw) {
    if (!depth_scale)
      throw py::value_error(std::string(arg) +
                            ": a uint16 depth image needs depth_scale (metres per unit, e.g. "
                            "0.001 for millimetres), got None");
    const auto r = contiguous<std::uint16_t>(a);
    return depthFromRaw(width, height, r.data(), *depth_scale);
  }
  if (depth_scale)
    throw py::value_error(std::string(arg) + ": depth_scale applies to uint16 depth only; a " +
                          std::string(py::str(a.dtype())) + " depth image is in metres already");
  const auto f = contiguous<float>(a);
  DepthImage out(width, height);
  if (!out.depth_m.empty()) std::memcpy(out.depth_m.data(), f.data(), out.depth_m.size() * sizeof(float));
  return out;
}

TriangleMesh toMesh(py::handle mesh, const char* arg) {
  if (!py::isinstance<py::sequence>(mesh) || py::isinstance<py::str>(mesh) || py::len(mesh) != 2)
    throw py::value_error(std::string(arg) + ": expected a (vertices, triangles) pair, got " +
                          std::string(py::str(py::type::of(mesh).attr("__name__"))));
  const py::sequence pair = py::reinterpret_borrow<py::sequence>(mesh);
  const std::string vertices_arg = std::string(arg) + " vertices", triangles_arg = std::string(arg) + " triangles";
  TriangleMesh out;
  out.vertices = toPoints(pair[0], vertices_arg.c_str());
  constexpr const char* expected = "a (T, 3) array of integers";
  const py::array t = asArray(pair[1], triangles_arg.c_str(), expected, "int64");
  // An empty list reads as float64; it still means "no triangles".
  const bool empty = t.size() == 0 && (t.ndim() == 1 || (t.ndim() == 2 && t.shape(1) == 3));
  if (empty) return out;
  if (!isInteger(t) || t.ndim() != 2 || t.shape(1) != 3) fail(triangles_arg.c_str(), expected, t);
  const auto idx = contiguous<std::int64_t>(t);
  const std::int64_t n = std::int64_t(out.vertices.size());
  out.triangles.resize(std::size_t(idx.shape(0)));
  const std::int64_t* p = idx.data();
  for (std::size_t i = 0; i < out.triangles.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const std::int64_t v = p[3 * i + std::size_t(c)];
      if (v < 0 || v >= n)
        throw py::value_error(triangles_arg + ": triangle " + std::to_string(i) + " refers to vertex " +
                              std::to_string(v) + ", but there are " + std::to_string(n) + " vertices");
      out.triangles[i][c] = int(v);
    }
  }
  return out;
}

std::map<FrameId, Pose3d> toPoseMap(py::handle poses, const char* arg) {
  if (!py::isinstance<py::dict>(poses))
    throw py::value_error(std::string(arg) + ": expected a dict {frame_id: (4, 4) pose}, got " +
                          std::string(py::str(py::type::of(poses).attr("__name__"))));
  std::map<FrameId, Pose3d> out;
  for (const auto& [key, value] : py::reinterpret_borrow<py::dict>(poses)) {
    if (!py::isinstance<py::int_>(key) || py::cast<long long>(key) < 0)
      throw py::value_error(std::string(arg) + ": frame ids must be non-negative ints, got " +
                            std::string(py::repr(key)));
    const FrameId id = py::cast<FrameId>(key);
    const std::string item = std::string(arg) + "[" + std::to_string(id) + "]";
    out[id] = toPose(value, item.c_str());
  }
  return out;
}

std::vector<openvdb::Coord> toCoords(py::handle ijk, const char* arg) {
  constexpr const char* expected = "an (N, 3) array of integers";
  const py::array a = asArray(ijk, arg, expected, "int64");
  if (!isInteger(a) || a.ndim() != 2 || a.shape(1) != 3) fail(arg, expected, a);
  const auto c = contiguous<std::int64_t>(a);
  std::vector<openvdb::Coord> out(std::size_t(c.shape(0)));
  const std::int64_t* p = c.data();
  constexpr std::int64_t lo = std::numeric_limits<openvdb::Int32>::min(),
                         hi = std::numeric_limits<openvdb::Int32>::max();
  for (std::size_t i = 0; i < out.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      const std::int64_t v = p[3 * i + std::size_t(k)];
      if (v < lo || v > hi)
        throw py::value_error(std::string(arg) + ": index " + std::to_string(v) + " does not fit in int32");
      out[i][k] = openvdb::Int32(v);
    }
  }
  return out;
}

Eigen::AlignedBox3d toBox(py::handle box, const char* arg) {
  if (box.is_none()) return Eigen::AlignedBox3d();
  if (!py::isinstance<py::sequence>(box) || py::isinstance<py::str>(box) || py::len(box) != 2)
    throw py::value_error(std::string(arg) + ": expected None or a (min (3,), max (3,)) pair, got " +
                          std::string(py::str(py::type::of(box).attr("__name__"))));
  const py::sequence pair = py::reinterpret_borrow<py::sequence>(box);
  const std::string lo = std::string(arg) + " min", hi = std::string(arg) + " max";
  return Eigen::AlignedBox3d(toVec3(pair[0], lo.c_str()), toVec3(pair[1], hi.c_str()));
}

// ---- C++ -> numpy ---------------------------------------------------------------------------------

py::array_t<double> toArray(const Pose3d& T) {
  py::array_t<double> out({4, 4});
  auto m = out.mutable_unchecked<2>();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = T.matrix()(r, c);
  return out;
}

py::array_t<double> toArray(const Vec3d& v) {
  py::array_t<double> out(3);
  for (int i = 0; i < 3; ++i) out.mutable_at(i) = v[i];
  return out;
}

py::array_t<float> toArray(const PointCloud& points) {
  py::array_t<float> out({py::ssize_t(points.size()), py::ssize_t(3)});
  float* p = out.mutable_data();
  for (std::size_t i = 0; i < points.size(); ++i)
    for (int k = 0; k < 3; ++k) p[3 * i + std::size_t(k)] = points[i][k];
  return out;
}

py::array_t<float> toArray(const DepthImage& depth) {
  py::array_t<float> out({py::ssize_t(depth.height), py::ssize_t(depth.width)});
  if (!depth.depth_m.empty())
    std::memcpy(out.mutable_data(), depth.depth_m.data(), depth.depth_m.size() * sizeof(float));
  return out;
}

py::tuple toArrays(const TriangleMesh& mesh) {
  py::array_t<std::int32_t> triangles({py::ssize_t(mesh.triangles.size()), py::ssize_t(3)});
  auto t = triangles.mutable_unchecked<2>();
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    for (int c = 0; c < 3; ++c) t(py::ssize_t(i), c) = mesh.triangles[i][c];
  return py::make_tuple(toArray(mesh.vertices), triangles);
}

py::dict toDict(const std::map<FrameId, Pose3d>& poses) {
  py::dict out;
  for (const auto& [id, T] : poses) out[py::int_(id)] = toArray(T);
  return out;
}

py::tuple toTuple(const openvdb::Coord& c) { return py::make_tuple(c.x(), c.y(), c.z()); }

py::object toArrays(const Eigen::AlignedBox3d& box) {
  if (box.isEmpty()) return py::none();
  return py::make_tuple(toArray(Vec3d(box.min())), toArray(Vec3d(box.max())));
}

py::object toTuple(const openvdb::CoordBBox& box) {
  if (box.empty()) return py::none();
  return py::make_tuple(toTuple(box.min()), toTuple(box.max()));
}

// ---- helpers for bound classes --------------------------------------------------------------------

std::string reprOfProperties(py::handle self) {
  const py::object type = py::type::of(self);
  const py::object property = py::module_::import("builtins").attr("property");
  std::string out = std::string(py::str(type.attr("__name__"))) + "(";
  bool first = true;
  for (const auto& [key, value] : py::dict(type.attr("__dict__"))) {  // a mappingproxy: copy it
    const std::string name = py::str(key);
    if (name.empty() || name[0] == '_' || !py::isinstance(value, property)) continue;
    out += (first ? "" : ", ") + name + "=" + std::string(py::repr(self.attr(key)));
    first = false;
  }
  return out + ")";
}

}  // namespace vdbmap::python
