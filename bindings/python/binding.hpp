// Shared parts of the Python module `vdbmap`: how each bind_*.cpp registers itself, and the
// conversions between numpy arrays and the library's types.
//
// The module is thin: conversions only. Each bind_<part>.cpp binds one part of the C++ API and
// registers itself with a static BindRegistration, so a new part (bind_sim.cpp, bind_explore.cpp)
// is added without editing any other file. Parts bind in BindOrder, so the types a part's
// signatures mention are already known to pybind11 and its docstrings name Python types.
// A part that binds a library of its own (sim, explore) can put it in a submodule (submodule()
// below: `import vdbmap.sim` works) described by stubs/vdbmap/sim.pyi, with `from . import sim as
// sim` in stubs/vdbmap/__init__.pyi; tests/python/test_stubs.py checks every stub against the module.
//
// Array conventions (checked here, with a ValueError naming the argument, the expected and the
// received shape and dtype):
//   points    (N, 3) float32 or float64, any strides (converted to float32, as the C++ API holds them)
//   depth     (H, W) float32/float64 metres, or uint16 raw units with depth_scale (metres per unit)
//   poses     (4, 4) float32 or float64, last row [0, 0, 0, 1]; returned as float64
//   vectors   (3,) float
// Nested lists are accepted wherever an array is and are read as float64 (or int64 for indices).
#pragma once

#include "vdbmap/camera.hpp"
#include "vdbmap/openvdb.hpp"
#include "vdbmap/triangle_mesh.hpp"
#include "vdbmap/types.hpp"

#include <Eigen/Geometry>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <map>
#include <memory>
#include <optional>
#include <string>

namespace vdbmap::python {

namespace py = pybind11;

/// The order in which the parts of the module are bound (lower first).
enum BindOrder : int {
  kBindTypes = 0,     ///< enums, intrinsics, poses
  kBindConfig = 10,   ///< parameter structs
  kBindVolume = 20,   ///< TsdfVolume, mesh extraction
  kBindMapper = 30,   ///< Mapper and its reports
  kBindIo = 40,       ///< files, datasets, log replay
  kBindEval = 50,     ///< surface evaluation
  kBindPlanner = 60,  ///< reserved for the planner
  kBindSim = 70,      ///< reserved for the simulator
  kBindExplore = 80,  ///< reserved for the exploration loop
};

using BindFunction = void (*)(py::module_& m);

/// Registers one part of the module; define one as a static object in each bind_*.cpp.
struct BindRegistration {
  BindRegistration(int order, const char* name, BindFunction bind);
};

/// Binds every registered part into `m`, in BindOrder (then by name).
void bindAllParts(py::module_& m);

/// A submodule `parent.name` that `import parent.name` also finds (pybind11's def_submodule alone
/// makes only `from parent import name` work).
py::module_ submodule(py::module_& parent, const char* name, const char* doc);

// ---- numpy -> C++ (raise ValueError naming `arg` on a wrong shape or dtype) ---------------------

/// (N, 3) float32/float64 -> points.
PointCloud toPoints(py::handle points, const char* arg);
/// (4, 4) float -> rigid transform (the rotation is checked by the C++ API that uses it).
Pose3d toPose(py::handle T, const char* arg);
/// (3,) float -> vector.
Vec3d toVec3(py::handle v, const char* arg);
/// (H, W) depth: float32/float64 in metres (depth_scale must be None), or uint16 raw units
/// (depth_scale required, metres per unit; raw 0 is invalid).
DepthImage toDepth(py::handle depth, const std::optional<double>& depth_scale, const char* arg);
/// A (vertices (V, 3) float, triangles (T, 3) integer) pair; triangles may be empty (T = 0) for
/// a point cloud. Indices must lie in [0, V).
TriangleMesh toMesh(py::handle mesh, const char* arg);
/// {frame_id: (4, 4) pose} -> map.
std::map<FrameId, Pose3d> toPoseMap(py::handle poses, const char* arg);
/// (N, 3) integer voxel indices.
std::vector<openvdb::Coord> toCoords(py::handle ijk, const char* arg);
/// None (an empty box) or a (min (3,), max (3,)) pair of float vectors.
Eigen::AlignedBox3d toBox(py::handle box, const char* arg);

// ---- C++ -> numpy (new arrays owned by Python) ----------------------------------------------------

py::array_t<double> toArray(const Pose3d& T);
py::array_t<double> toArray(const Vec3d& v);
py::array_t<float> toArray(const PointCloud& points);
py::array_t<float> toArray(const DepthImage& depth);
py::tuple toArrays(const TriangleMesh& mesh);
py::dict toDict(const std::map<FrameId, Pose3d>& poses);
py::tuple toTuple(const openvdb::Coord& c);
/// None for an empty box, else (min (3,), max (3,)) float64.
py::object toArrays(const Eigen::AlignedBox3d& box);
/// None for an empty box, else ((i, j, k) min, (i, j, k) max), inclusive.
py::object toTuple(const openvdb::CoordBBox& box);

// ---- enums given by name ------------------------------------------------------------------------------

/// An enum argument given as the enum or as its name (parsed by the C++ parse function, whose
/// ValueError lists the accepted names); anything else is a TypeError naming the argument.
template <typename E>
E toEnum(py::handle value, E (*parse)(const std::string&), const char* arg) {
  if (py::isinstance<py::str>(value)) return parse(value.cast<std::string>());
  try {
    return value.cast<E>();
  } catch (const py::cast_error&) {
    const py::object expected = py::type::of<E>().attr("__name__"), got = py::type::of(value).attr("__name__");
    throw py::type_error(std::string(arg) + ": expected " + std::string(py::str(expected)) + " or its name, got " +
                         std::string(py::str(got)));
  }
}

/// A read-write enum field that also accepts the enum's name: config.weighting = "constant".
template <typename T, typename E, typename... Options>
void defEnumField(py::class_<T, Options...>& cls, const char* name, E T::*member, E (*parse)(const std::string&),
                  const char* doc) {
  cls.def_property(
      name, [member](const T& self) { return self.*member; },
      [member, parse, name](T& self, py::handle value) { self.*member = toEnum(value, parse, name); }, doc);
}

// ---- helpers for bound classes ----------------------------------------------------------------------

/// "TypeName(field=value, ...)" over the class's properties, for __repr__.
std::string reprOfProperties(py::handle self);

/// Adds a keyword constructor T(**fields) (unknown names raise TypeError), __repr__ listing the
/// fields, __copy__ and __deepcopy__ to a parameter struct with default constructor and copies.
template <typename T, typename... Options>
void addStructProtocol(py::class_<T, Options...>& cls) {
  cls.def(py::init([](const py::kwargs& fields) {
            // Made on the heap: GCC 12 warns (wrongly) that a stack default holding a vector may be uninitialized.
            py::object obj = py::cast(std::make_unique<T>());
            for (const auto& [key, value] : fields) {
              const std::string name = py::str(key);
              if (name.empty() || name[0] == '_' || !py::hasattr(py::type::of(obj), key))
                throw py::type_error(std::string(py::str(py::type::of(obj).attr("__name__"))) +
                                     "() got an unexpected keyword argument '" + name + "'");
              py::setattr(obj, key, value);
            }
            return obj.cast<T>();
          }),
          "Defaults from C++; any field may be given by keyword.");
  cls.def("__repr__", [](py::handle self) { return reprOfProperties(self); });
  cls.def("__copy__", [](const T& self) { return T(self); });
  cls.def(
      "__deepcopy__", [](const T& self, py::dict) { return T(self); }, py::arg("memo"));
}

}  // namespace vdbmap::python
