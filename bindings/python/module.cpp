// The Python module `vdbmap`: the module object, its exceptions, and every registered part.
#include "binding.hpp"

#include "vdbmap/io/errors.hpp"
#include "vdbmap/version.hpp"

#include <filesystem>
#include <string>
#include <utility>
#include <vector>
#include <system_error>

namespace vdbmap::python {
namespace {

/// C++ exceptions arrive with their messages as: std::invalid_argument (bad parameters, bad
/// frames) -> ValueError (pybind11's own rule), vdbmap::FileError (a file that cannot be opened, read
/// or written, or is malformed) -> OSError, io::BadFrameError -> vdbmap.BadFrameError (an OSError
/// with frame_index), std::filesystem::filesystem_error -> OSError, std::out_of_range ->
/// IndexError (pybind11's rule), anything else -> RuntimeError.
void registerExceptions(py::module_& m) {
  static py::exception<io::BadFrameError> bad_frame(m, "BadFrameError", PyExc_OSError);
  bad_frame.doc() =
      "A frame of a dataset that cannot be used (missing, corrupt or wrongly sized file, invalid pose). "
      "An OSError; `frame_index` is the frame's index in the sequence.";
  py::register_local_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const io::BadFrameError& e) {
      py::object error = py::handle(bad_frame.ptr())(e.what());  // an instance, to carry frame_index
      error.attr("frame_index") = e.frameIndex();
      PyErr_SetObject(bad_frame.ptr(), error.ptr());
    } catch (const vdbmap::FileError& e) {
      PyErr_SetString(PyExc_OSError, e.what());
    } catch (const std::filesystem::filesystem_error& e) {
      PyErr_SetString(PyExc_OSError, e.what());
    }
  });
}

/// The classes renamed when every settings type took the suffix Config: their old names still
/// resolve, through the module's __getattr__ (PEP 562), with a DeprecationWarning.
void keepRenamedClasses(py::module_ m, const std::vector<std::pair<std::string, std::string>>& renamed) {
  const std::string module_name = py::str(m.attr("__name__"));
  m.attr("__getattr__") = py::cpp_function(
      [module_name, renamed](const std::string& name) -> py::object {
        for (const auto& [old_name, new_name] : renamed) {
          if (name != old_name) continue;
          const std::string message = module_name + "." + old_name + " is renamed " + module_name + "." + new_name;
          if (PyErr_WarnEx(PyExc_DeprecationWarning, message.c_str(), 1) != 0) throw py::error_already_set();
          return py::module_::import(module_name.c_str()).attr(new_name.c_str());
        }
        throw py::attribute_error("module '" + module_name + "' has no attribute '" + name + "'");
      },
      py::arg("name"));
}

}  // namespace
}  // namespace vdbmap::python

PYBIND11_MODULE(vdbmap, m) {
  using namespace vdbmap::python;
  m.doc() =
      "vdbmap: globally consistent TSDF mapping on OpenVDB, from Python.\n\n"
      "A thin binding of the C++ library: TsdfVolume (exact integration and de-integration), Mapper "
      "(consistency modes, pose updates, budgeted re-integration), dataset readers and log replay, mesh "
      "extraction, surface evaluation and .vdb files.\n\n"
      "Arrays: points (N, 3) float32/float64; depth (H, W) float32/float64 in metres or uint16 with "
      "depth_scale (metres per unit); poses (4, 4) float64 T_W_S (sensor in world). Wrong shapes or dtypes "
      "raise ValueError naming the argument. C++ errors keep their messages: bad parameters raise "
      "ValueError, file problems OSError, others RuntimeError. Long calls release the GIL; one object must "
      "not be used from two threads at once.";
  m.attr("__version__") = vdbmap::kVersion;
  registerExceptions(m);
  bindAllParts(m);
  keepRenamedClasses(m, {{"ReplayOptions", "ReplayConfig"}, {"LogWriterOptions", "LogWriterConfig"}});
  keepRenamedClasses(m.attr("planner"), {{"AlcParams", "AlcConfig"},
                                         {"CostParams", "CostConfig"},
                                         {"EscapeParams", "EscapeConfig"},
                                         {"ExplorationParams", "ExplorationManagerConfig"},
                                         {"FrontierParams", "FrontierConfig"},
                                         {"PathParams", "PathConfig"},
                                         {"RefinementParams", "RefinementConfig"},
                                         {"TourParams", "TourConfig"},
                                         {"TrajectoryParams", "TrajectoryConfig"},
                                         {"ViewpointParams", "ViewpointConfig"}});
  keepRenamedClasses(m.attr("sim"), {{"PoseGraphSolveOptions", "PoseGraphSolveConfig"}});
}
