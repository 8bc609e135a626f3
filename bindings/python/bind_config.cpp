// Parameter structs. Defaults live in C++ only: a struct made in Python starts from them.
#include "binding.hpp"

#include "vdbmap/config.hpp"
#include "vdbmap/eval.hpp"
#include "vdbmap/mapper.hpp"
#include "vdbmap/set_cover.hpp"

namespace vdbmap::python {
namespace {

void bindTsdfConfig(py::module_& m) {
  py::class_<TsdfConfig> c(m, "TsdfConfig", "The map's geometry and the meaning of its values.");
  addStructProtocol(c);
  c.def_readwrite("voxel_size_m", &TsdfConfig::voxel_size_m, "edge of a voxel in metres; [1e-4, 10]")
      .def_readwrite("truncation_vox", &TsdfConfig::truncation_vox, "truncation distance in voxels; [1, 100]");
  defEnumField(c, "weighting", &TsdfConfig::weighting, &parseWeighting,
               "Weighting (or its name: 'constant', 'inverse_square')");
  c.def_readwrite("min_weight", &TsdfConfig::min_weight,
                  "tau_w: a voxel is known when its weight sum exceeds this; [0, 1e6)")
      .def_readwrite("occupancy_threshold_vox", &TsdfConfig::occupancy_threshold_vox,
                     "a known voxel is occupied when its tsdf is below this many voxels; "
                     "[-truncation_vox, truncation_vox]")
      .def_readwrite("weight_scale", &TsdfConfig::weight_scale,
                     "fixed-point units of one ray of weight 1; 0 (default) = chosen from the max range; "
                     "0 or a power of two in [1024, 2^20]")
      .def("truncation_m", &TsdfConfig::truncation_m, "truncation_vox * voxel_size_m")
      .def("validate", &TsdfConfig::validate, "Raises ValueError naming the field and its allowed range.");
}

void bindIntegratorConfig(py::module_& m) {
  py::class_<IntegratorConfig> c(m, "IntegratorConfig",
                                 "How frames become ray updates; part of a map's identity (a frame is "
                                 "de-integrated with the settings it was integrated with).");
  addStructProtocol(c);
  c.def_readwrite("min_range_m", &IntegratorConfig::min_range_m,
                  "points closer than this are invalid (skipped, counted); [0, max_range_m)")
      .def_readwrite("max_range_m", &IntegratorConfig::max_range_m,
                     "points beyond carve free space up to it and add no surface; (min_range_m, 1000]")
      .def_readwrite("threads", &IntegratorConfig::threads,
                     "worker threads; 0 = all cores; the map does not depend on it; [0, 1024]")
      .def("validate", &IntegratorConfig::validate, "Raises ValueError naming the field and its allowed range.");
  defEnumField(c, "ray_mode", &IntegratorConfig::ray_mode, &parseRayMode, "RayMode (or 'projective', 'merged', 'per_ray')");
}

void bindReintegrationConfig(py::module_& m) {
  py::class_<ReintegrationConfig> c(m, "ReintegrationConfig", "Gates and budget of re-integration.");
  addStructProtocol(c);
  c.def_readwrite("gate_translation_m", &ReintegrationConfig::gate_translation_m,
                  "pose changes below both gates are ignored; [0, 1000]")
      .def_readwrite("gate_rotation_deg", &ReintegrationConfig::gate_rotation_deg, "[0, 180]")
      .def_readwrite("budget_ms", &ReintegrationConfig::budget_ms,
                     "time budget of one frame's cycle: its add_depth_frame()/add_point_frame() and the reintegrate() "
                     "after it (at least one "
                     "frame is processed; a call without a new frame has the whole budget); (0, 1e6]")
      .def_readwrite("budget_frames", &ReintegrationConfig::budget_frames,
                     "also stop after this many frames per cycle; 0 = no limit")
      .def("validate", &ReintegrationConfig::validate, "Raises ValueError naming the field and its allowed range.");
}

void bindSetCoverConfig(py::module_& m) {
  py::class_<SetCoverConfig> c(m, "SetCoverConfig", "Set-cover keyframe pruning (keyframes mode).");
  addStructProtocol(c);
  c.def_readwrite("n_ob", &SetCoverConfig::n_ob, "how many kept frames should see each coarse cell; [1, 1000]")
      .def_readwrite("tau_gain", &SetCoverConfig::tau_gain,
                     "stop selecting when the best gain (cells still needed) is <= this; [0, 1e9]")
      .def_readwrite("block_size_m", &SetCoverConfig::block_size_m,
                     "blocks partition space by camera position, each solved on its own; (0, 1e4]")
      .def_readwrite("cell_size_vox", &SetCoverConfig::cell_size_vox, "coarse cell edge in voxels; [1, 64]")
      .def_readwrite("solve_period_frames", &SetCoverConfig::solve_period_frames,
                     "the mapper re-solves dirty blocks every this many frames; [1, 1e6]")
      .def_readwrite("solve_in_background", &SetCoverConfig::solve_in_background,
                     "run each solve on a worker thread, collected when the next is due (True), or inside "
                     "the frame that triggers it (False)")
      .def("validate", &SetCoverConfig::validate, "Raises ValueError naming the field and its allowed range.");
}

void bindMapperConfig(py::module_& m) {
  py::class_<MapperConfig> c(m, "MapperConfig", "Everything a Mapper needs; nested structs are edited in place.");
  addStructProtocol(c);
  defEnumField(c, "mode", &MapperConfig::mode, &parseConsistencyMode,
               "ConsistencyMode (or 'none', 'submap', 'all', 'keyframes')");
  c.def_readwrite("tsdf", &MapperConfig::tsdf, "TsdfConfig")
      .def_readwrite("integrator", &MapperConfig::integrator, "IntegratorConfig")
      .def_readwrite("reintegration", &MapperConfig::reintegration, "ReintegrationConfig")
      .def_readwrite("set_cover", &MapperConfig::set_cover, "SetCoverConfig (keyframes mode)")
      .def_readwrite("submap_frames", &MapperConfig::submap_frames, "submap mode: frames per rigid submap; [1, 1e6]")
      .def_readwrite("depth_unit_m", &MapperConfig::depth_unit_m,
                     "keyframe store quantization of depth and points in metres; (0, 0.1]")
      .def("validate", &MapperConfig::validate, "Raises ValueError naming the field and its allowed range.");
}

void bindEvalConfig(py::module_& m) {
  py::class_<EvalConfig> c(m, "EvalConfig", "Surface evaluation against ground truth.");
  addStructProtocol(c);
  c.def_readwrite("completeness_threshold_m", &EvalConfig::completeness_threshold_m,
                  "ground truth within this of the map counts as complete (usually 2 voxels); (0, 10]")
      .def_readwrite("sample_spacing_m", &EvalConfig::sample_spacing_m,
                     "spacing of the ground-truth surface samples; (0, 1]")
      .def("validate", &EvalConfig::validate, "Raises ValueError naming the field and its allowed range.");
}

void bindConfig(py::module_& m) {
  bindTsdfConfig(m);
  bindIntegratorConfig(m);
  bindReintegrationConfig(m);
  bindSetCoverConfig(m);
  bindMapperConfig(m);
  bindEvalConfig(m);
}

const BindRegistration registration(kBindConfig, "config", &bindConfig);

}  // namespace
}  // namespace vdbmap::python
