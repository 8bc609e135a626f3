// Files and datasets: the log reader and dataset importers, log replay through a Mapper, the log
// writer, depth PNGs, point clouds, meshes, trajectories, and map file inspection.
#include "binding.hpp"
#include "object_lock.hpp"

#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/log_writer.hpp"
#include "vdbmap/io/mesh_io.hpp"
#include "vdbmap/io/png_io.hpp"
#include "vdbmap/io/point_cloud_io.hpp"
#include "vdbmap/io/sensor_info.hpp"
#include "vdbmap/io/tum_trajectory.hpp"
#include "vdbmap/io/log_replay.hpp"
#include "vdbmap/map_file.hpp"

#include <pybind11/functional.h>

#include <functional>

namespace vdbmap::python {
namespace {

using io::StampedPose;

/// Time-stamped poses <-> (timestamps float64 (N,), poses float64 (N, 4, 4)).
py::tuple trajectoryToArrays(const std::vector<StampedPose>& poses) {
  const py::ssize_t n = py::ssize_t(poses.size());
  py::array_t<double> t(n);
  py::array_t<double> T({n, py::ssize_t(4), py::ssize_t(4)});
  auto tt = t.mutable_unchecked<1>();
  auto TT = T.mutable_unchecked<3>();
  for (py::ssize_t i = 0; i < n; ++i) {
    tt(i) = poses[std::size_t(i)].timestamp_s;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) TT(i, r, c) = poses[std::size_t(i)].T_W_S.matrix()(r, c);
  }
  return py::make_tuple(t, T);
}

std::vector<StampedPose> toStampedPoses(py::handle timestamps, py::handle poses) {
  const py::array t = py::module_::import("numpy").attr("asarray")(timestamps, "float64");
  const py::array T = py::module_::import("numpy").attr("asarray")(poses, "float64");
  if (t.ndim() != 1)
    throw py::value_error("timestamps: expected an (N,) array of float64, got " + std::to_string(t.ndim()) +
                          " dimensions");
  if (T.ndim() != 3 || T.shape(0) != t.shape(0) || T.shape(1) != 4 || T.shape(2) != 4)
    throw py::value_error("poses: expected an (N, 4, 4) array with N = " + std::to_string(t.shape(0)) +
                          " (one pose per timestamp), got " + std::string(py::str(T.attr("shape"))));
  std::vector<StampedPose> out(std::size_t(t.shape(0)));
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i].timestamp_s = py::cast<double>(t[py::int_(i)]);
    const std::string arg = "poses[" + std::to_string(i) + "]";
    out[i].T_W_S = toPose(T[py::int_(i)], arg.c_str());
  }
  return out;
}

void bindSensor(py::module_& m) {
  py::class_<io::SensorInfo> s(m, "SensorInfo", "The sensor of a log or dataset (sensor.json).");
  addStructProtocol(s);
  s.def_readwrite("kind", &io::SensorInfo::kind, "SensorKind")
      .def_readwrite("intrinsics", &io::SensorInfo::intrinsics, "CameraIntrinsics (depth sensors)")
      .def_readwrite("depth_scale", &io::SensorInfo::depth_scale, "metres per depth unit of the PNG files, > 0")
      .def_readwrite("invalid_depth_raw", &io::SensorInfo::invalid_depth_raw,
                     "a raw value meaning no depth besides 0 (7-Scenes: 65535); 0 = none")
      .def_readwrite("min_range_m", &io::SensorInfo::min_range_m, ">= 0")
      .def_readwrite("max_range_m", &io::SensorInfo::max_range_m, "> min_range_m")
      .def("validate", &io::SensorInfo::validate, "Raises ValueError naming the field and its allowed range.");
  m.def("read_sensor_json", &io::readSensorJson, py::arg("path"), "Reads sensor.json; OSError on bad content.");
  m.def("write_sensor_json", &io::writeSensorJson, py::arg("path"), py::arg("sensor"),
        "Writes sensor.json atomically.");
}

void bindFrames(py::module_& m) {
  py::class_<io::FrameRecord> r(m, "FrameRecord", "One frame as listed (nothing read yet).");
  r.def_readonly("index", &io::FrameRecord::index, "position in the sequence, 0-based")
      .def_readonly("timestamp_s", &io::FrameRecord::timestamp_s, "seconds, strictly increasing")
      .def_readonly("file", &io::FrameRecord::file, "depth PNG or .ply/.pcd/.bin points")
      .def_property_readonly(
          "T_W_S", [](const io::FrameRecord& f) { return toArray(f.T_W_S); }, "(4, 4) the pose the dataset gives")
      .def_readonly("source", &io::FrameRecord::source, "where it was listed, e.g. 'log/frames.csv:13'")
      .def_readonly("problem", &io::FrameRecord::problem, "non-empty: load() raises BadFrameError with it")
      .def("__repr__", [](py::handle self) { return reprOfProperties(self); });

  py::class_<io::Frame> f(m, "Frame", "One loaded frame: a depth image (metres) or points, with its pose.");
  f.def_readonly("index", &io::Frame::index, "position in the sequence, 0-based")
      .def_readonly("timestamp_s", &io::Frame::timestamp_s, "seconds")
      .def_property_readonly(
          "T_W_S", [](const io::Frame& x) { return toArray(x.T_W_S); }, "(4, 4) float64")
      .def_property_readonly(
          "is_depth", [](const io::Frame& x) { return x.data.isDepth(); }, "a depth image (else points)")
      .def_property_readonly(
          "depth",
          [](const io::Frame& x) -> py::object {
            if (!x.data.isDepth()) return py::none();
            return toArray(x.data.depthImage());
          },
          "(H, W) float32 metres (0 = invalid) for depth frames, else None")
      .def_property_readonly(
          "points_S",
          [](const io::Frame& x) -> py::object {
            if (x.data.isDepth()) return py::none();
            return toArray(x.data.points_S());
          },
          "(N, 3) float32 in the sensor frame for point frames, else None")
      .def("__repr__", [](const io::Frame& x) {
        return "Frame(index=" + std::to_string(x.index) +
               ", timestamp_s=" + std::string(py::repr(py::float_(x.timestamp_s))) +
               ", is_depth=" + (x.data.isDepth() ? "True" : "False") + ")";
      });

  py::class_<io::CorrectionEvent> c(m, "CorrectionEvent",
                                    "A loop-closure correction: optimised poses published at event_timestamp_s, "
                                    "applied once that frame is integrated.");
  c.def_readonly("event_timestamp_s", &io::CorrectionEvent::event_timestamp_s, "when the back end published it")
      .def_readonly("event_frame", &io::CorrectionEvent::event_frame, "index of the frame at the event")
      .def_property_readonly(
          "poses", [](const io::CorrectionEvent& e) { return trajectoryToArrays(e.poses); },
          "(timestamps float64 (N,), T_W_S float64 (N, 4, 4)): corrected poses at any stamps up to the event; "
          "every integrated frame moves, its correction interpolated between them")
      .def_readonly("file", &io::CorrectionEvent::file, "corrections/<event_timestamp>.txt")
      .def("__repr__", [](const io::CorrectionEvent& e) {
        return "CorrectionEvent(event_frame=" + std::to_string(e.event_frame) +
               ", poses=" + std::to_string(e.poses.size()) + ")";
      });
}

std::size_t checkedIndex(const io::FrameSource& s, py::ssize_t i) {
  const py::ssize_t n = py::ssize_t(s.size());
  if (i < -n || i >= n)
    throw py::index_error("frame " + std::to_string(i) + " out of range (" + std::to_string(n) + " frames)");
  return std::size_t(i < 0 ? i + n : i);
}

io::Frame loadFrame(const io::FrameSource& s, py::ssize_t i) {
  const std::size_t k = checkedIndex(s, i);
  py::gil_scoped_release nogil;
  return s.load(k);
}

void bindFrameSource(py::module_& m) {
  py::class_<io::FrameSource> s(m, "FrameSource",
                                "A recorded sequence (our log format or a dataset layout), random access; "
                                "source[i] loads frame i.");
  s.def_property_readonly("format", &io::FrameSource::format, "'log', '7scenes', 'iclnuim', ...")
      .def_property_readonly("root", &io::FrameSource::root, "the folder it was read from")
      .def_property_readonly("description", &io::FrameSource::description,
                             "where intrinsics, depth scale and poses came from")
      .def_property_readonly(
          "sensor", [](const io::FrameSource& x) { return x.sensor(); }, "SensorInfo (a copy)")
      .def("__len__", &io::FrameSource::size)
      .def(
          "record", [](const io::FrameSource& x, py::ssize_t i) { return x.record(checkedIndex(x, i)); }, py::arg("i"),
          "The listing of frame i (negative counts from the end).")
      .def(
          "records", [](const io::FrameSource& x) { return x.records(); }, "Every frame's listing.")
      .def("load", &loadFrame, py::arg("i"),
           "Reads frame i. BadFrameError (an OSError) when its file is missing, corrupt or of the wrong kind or "
           "size, or its listed pose was invalid.")
      .def("__getitem__", &loadFrame, py::arg("i"))
      .def_property_readonly(
          "corrections", [](const io::FrameSource& x) { return x.corrections(); },
          "CorrectionEvents sorted by event time")
      .def_property_readonly(
          "ground_truth", [](const io::FrameSource& x) { return trajectoryToArrays(x.groundTruth()); },
          "(timestamps (N,), T_W_S (N, 4, 4)) true poses when the dataset has them separately, else empty")
      .def("find_frame", &io::FrameSource::findFrame, py::arg("timestamp_s"),
           py::arg("tolerance_s") = io::kTimestampMatchTolerance_s,
           "The index of the frame within tolerance_s of timestamp_s, or None.")
      .def("__repr__", [](const io::FrameSource& x) {
        return "FrameSource(format=" + std::string(py::repr(py::str(x.format()))) +
               ", frames=" + std::to_string(x.size()) + ", root=" + std::string(py::repr(py::str(x.root().string()))) +
               ")";
      });

  m.def(
      "open_dataset",
      [](const std::filesystem::path& path, py::handle format) {
        const io::DatasetFormat f = toEnum(format, &io::parseDatasetFormat, "format");
        py::gil_scoped_release nogil;
        return io::openDataset(path, f);
      },
      py::arg("path"), py::arg("format") = io::DatasetFormat::Auto,
      "Opens a log or dataset folder in place (format detected, or forced by DatasetFormat or its name). "
      "OSError naming the file and line for a missing folder or malformed listing.");
  m.def("detect_dataset_format", &io::detectDatasetFormat, py::arg("path"),
        "Which layout the folder holds, or DatasetFormat.Auto when none is recognised.");
}

void bindReplay(py::module_& m) {
  py::class_<ReplayConfig> o(m, "ReplayConfig", "How replay_log integrates a sequence.");
  addStructProtocol(o);
  o.def_readwrite("frame_stride", &ReplayConfig::frame_stride, "integrate every k-th frame; [1, 1e6]")
      .def_readwrite("apply_corrections", &ReplayConfig::apply_corrections, "False: ignore corrections/")
      .def_readwrite("load_ahead", &ReplayConfig::load_ahead,
                     "True: load the next frame while this one integrates; False: load each frame before its cycle "
                     "starts (time cycles as bench/open3d_7scenes.py times Open3D)")
      .def_readwrite("progress", &ReplayConfig::progress,
                     "None or a callable(frames_done, frames_to_do) called after every frame")
      .def("validate", &ReplayConfig::validate, "Raises ValueError naming the field and its allowed range.");
  defEnumField(o, "on_bad_frame", &ReplayConfig::on_bad_frame, &parseOnBadFrame, "OnBadFrame (or 'fail', 'skip')");

  py::class_<BadFrame> b(m, "BadFrame", "A frame skipped by replay_log (on_bad_frame 'skip').");
  b.def_readonly("index", &BadFrame::index, "the frame's index in the sequence")
      .def_readonly("message", &BadFrame::message, "why it was skipped, naming its file")
      .def("__repr__", [](py::handle self) { return reprOfProperties(self); });

  py::class_<ReplayResult> r(m, "ReplayResult", "What replay_log did; times in seconds unless named _ms.");
  r.def_readonly("frames_total", &ReplayResult::frames_total, "frames the log lists, after the stride")
      .def_readonly("frames_integrated", &ReplayResult::frames_integrated, "frames given to the mapper")
      .def_readonly("frames_skipped", &ReplayResult::frames_skipped, "bad frames skipped (on_bad_frame 'skip')")
      .def_readonly("bad_frames", &ReplayResult::bad_frames, "list of BadFrame")
      .def_readonly("correction_events", &ReplayResult::correction_events, "events applied")
      .def_readonly("points_invalid", &ReplayResult::points_invalid, "NaN, zero or too close, over all frames")
      .def_readonly("integrate_s", &ReplayResult::integrate_s, "integration only")
      .def_readonly("ms_per_frame_median", &ReplayResult::ms_per_frame_median, "integration only")
      .def_readonly("integrate_ms_max", &ReplayResult::integrate_ms_max, "integration only")
      .def_readonly("cycle_ms_median", &ReplayResult::cycle_ms_median,
                    "whole cycle: integration, corrections and the background cycle after each frame")
      .def_readonly("ms_per_frame_p99", &ReplayResult::ms_per_frame_p99, "whole cycle")
      .def_readonly("ms_per_frame_max", &ReplayResult::ms_per_frame_max, "whole cycle")
      .def_readonly("background_frames", &ReplayResult::background_frames,
                    "frames the background cycles processed (re-integrations and drops)")
      .def_readonly("pruned_frames_deintegrated", &ReplayResult::pruned_frames_deintegrated,
                    "frames set cover dropped, de-integrated in background cycles")
      .def_readonly("load_s", &ReplayResult::load_s, "reading and decoding frame files (overlaps integration)")
      .def_readonly("wall_s", &ReplayResult::wall_s, "the whole replay")
      .def("__repr__", [](py::handle self) { return reprOfProperties(self); });

  m.def(
      "replay_log",
      [](const io::FrameSource& source, Mapper& mapper, ReplayConfig options) {
        // The GIL is released for the replay; the progress callback takes it back, and Ctrl-C stops
        // the replay after the current frame (the KeyboardInterrupt propagates).
        const std::function<void(std::size_t, std::size_t)> user = std::move(options.progress);
        options.progress = [user](std::size_t done, std::size_t total) {
          py::gil_scoped_acquire gil;
          if (PyErr_CheckSignals() != 0) throw py::error_already_set();
          if (user) user(done, total);
        };
        // The mapper is locked for writing; the callback runs on this thread, so it may read the mapper.
        return withLock(&mapper, Access::Write, [&] { return replayLog(source, mapper, options); });
      },
      py::arg("source"), py::arg("mapper"), py::arg("options") = ReplayConfig{},
      "Replays a sequence into a mapper as the CLI's `integrate` does: frames in order with the poses the log "
      "gives, corrections applied once their frame is integrated, one budgeted re-integration cycle per "
      "frame, and the queue drained at the end. With on_bad_frame 'fail' the first bad frame raises "
      "BadFrameError.");
}

void bindFiles(py::module_& m) {
  m.def(
      "read_depth_png",
      [](const std::filesystem::path& path, double depth_scale, std::uint16_t invalid_raw) {
        DepthImage d;
        {
          py::gil_scoped_release nogil;
          d = io::readDepthPng(path, depth_scale, invalid_raw);
        }
        return toArray(d);
      },
      py::arg("path"), py::arg("depth_scale"), py::arg("invalid_raw") = 0,
      "A 16-bit gray PNG as depth (H, W) float32 metres: value * depth_scale; 0 and invalid_raw (when "
      "non-zero) become 0 = invalid.");
  m.def(
      "write_depth_png",
      [](const std::filesystem::path& path, py::handle depth, double depth_scale) {
        const DepthImage d = toDepth(depth, std::nullopt, "depth");
        std::size_t clipped = 0;
        py::gil_scoped_release nogil;
        io::writeDepthPng(path, d, depth_scale, &clipped);
        return clipped;
      },
      py::arg("path"), py::arg("depth"), py::arg("depth_scale"),
      "Writes depth (H, W) metres as a 16-bit PNG, value = round(depth / depth_scale); invalid or too large "
      "depths are written as 0. Returns how many finite positive depths were too large.");
  m.def(
      "read_png",
      [](const std::filesystem::path& path) {
        io::PngImage img;
        {
          py::gil_scoped_release nogil;
          img = io::readPng(path);
        }
        std::vector<py::ssize_t> shape{img.height, img.width};
        if (img.channels > 1) shape.push_back(img.channels);
        py::array_t<std::uint16_t> out(shape);
        std::copy(img.samples.begin(), img.samples.end(), out.mutable_data());
        return out;
      },
      py::arg("path"),
      "Any PNG's raw samples as uint16: (H, W) for gray, (H, W, C) otherwise (palette and low bit depths "
      "expanded to 8-bit).");
  m.def(
      "read_point_cloud",
      [](const std::filesystem::path& path) {
        PointCloud p;
        {
          py::gil_scoped_release nogil;
          p = io::readPointCloud(path);
        }
        return toArray(p);
      },
      py::arg("path"), "Points (N, 3) float32 from PLY, PCD or raw float32 .bin (by extension).");
  m.def(
      "write_point_cloud",
      [](const std::filesystem::path& path, py::handle points) {
        const PointCloud p = toPoints(points, "points");
        py::gil_scoped_release nogil;
        io::writePointCloud(path, p);
      },
      py::arg("path"), py::arg("points"), "Writes .ply, .pcd or .bin (by extension) atomically.");
  m.def(
      "read_triangle_mesh",
      [](const std::filesystem::path& path) {
        TriangleMesh mesh;
        {
          py::gil_scoped_release nogil;
          mesh = io::readTriangleMesh(path);
        }
        return toArrays(mesh);
      },
      py::arg("path"), "(vertices float32 (V, 3), triangles int32 (T, 3)) from PLY, OBJ or OFF (polygons fanned).");
  m.def(
      "write_ply_mesh",
      [](const std::filesystem::path& path, py::handle mesh) {
        const TriangleMesh tm = toMesh(mesh, "mesh");
        py::gil_scoped_release nogil;
        io::writePlyMesh(path, tm);
      },
      py::arg("path"), py::arg("mesh"), "Writes a (vertices, triangles) mesh as binary PLY, atomically.");
  m.def(
      "read_tum_trajectory",
      [](const std::filesystem::path& path, bool require_increasing) {
        return trajectoryToArrays(io::readTumTrajectory(path, require_increasing));
      },
      py::arg("path"), py::arg("require_increasing") = true,
      "A TUM trajectory as (timestamps float64 (N,), T_W_S float64 (N, 4, 4)).");
  m.def(
      "write_tum_trajectory",
      [](const std::filesystem::path& path, py::handle timestamps, py::handle poses) {
        io::writeTumTrajectory(path, toStampedPoses(timestamps, poses));
      },
      py::arg("path"), py::arg("timestamps"), py::arg("poses"),
      "Writes (timestamps (N,), poses (N, 4, 4)) in TUM format atomically.");
}

void bindLogWriter(py::module_& m) {
  py::class_<io::LogWriterConfig> o(m, "LogWriterConfig", "Options of LogWriter.");
  addStructProtocol(o);
  o.def_readwrite("points_extension", &io::LogWriterConfig::points_extension, "'.bin', '.ply' or '.pcd'")
      .def_readwrite("flush_every_frames", &io::LogWriterConfig::flush_every_frames,
                     "rewrite frames.csv every this many frames; 0 = only at flush()/close()")
      .def_readwrite("overwrite", &io::LogWriterConfig::overwrite, "allow a folder that already holds a log")
      .def("validate", &io::LogWriterConfig::validate, "Raises ValueError naming the field and its allowed range.");

  py::class_<io::LogWriter> w(m, "LogWriter",
                              "Writes our log format (sensor.json, frames.csv, frame files, corrections/, "
                              "groundtruth.txt). A context manager: leaving the block closes it.");
  w.def(py::init<const std::filesystem::path&, const io::SensorInfo&, io::LogWriterConfig>(), py::arg("folder"),
        py::arg("sensor"), py::arg("options") = io::LogWriterConfig{},
        "Creates the folder and writes sensor.json. OSError when it already holds a log (unless overwrite).")
      .def(
          "add_depth_frame",
          [](io::LogWriter& self, double timestamp_s, py::handle depth, py::handle T_W_S) {
            const DepthImage d = toDepth(depth, std::nullopt, "depth");
            const Pose3d T = toPose(T_W_S, "T_W_S");
            py::gil_scoped_release nogil;
            return self.addDepthFrame(timestamp_s, d, T);
          },
          py::arg("timestamp_s"), py::arg("depth"), py::arg("T_W_S"),
          "Writes depth/<index>.png with the sensor's depth_scale and lists the frame; returns its index.")
      .def(
          "add_points_frame",
          [](io::LogWriter& self, double timestamp_s, py::handle points_S, py::handle T_W_S) {
            const PointCloud p = toPoints(points_S, "points_S");
            const Pose3d T = toPose(T_W_S, "T_W_S");
            py::gil_scoped_release nogil;
            return self.addPointsFrame(timestamp_s, p, T);
          },
          py::arg("timestamp_s"), py::arg("points_S"), py::arg("T_W_S"),
          "Writes points/<index><points_extension> and lists the frame; returns its index.")
      .def(
          "add_correction",
          [](io::LogWriter& self, double event_timestamp_s, py::handle timestamps, py::handle poses) {
            self.addCorrection(event_timestamp_s, toStampedPoses(timestamps, poses));
          },
          py::arg("event_timestamp_s"), py::arg("timestamps"), py::arg("poses"),
          "Writes corrections/<event_timestamp>.txt: corrected poses (N, 4, 4) of frames already added, at "
          "their timestamps (N,).")
      .def(
          "add_ground_truth",
          [](io::LogWriter& self, double timestamp_s, py::handle T_W_S) {
            self.addGroundTruth(timestamp_s, toPose(T_W_S, "T_W_S"));
          },
          py::arg("timestamp_s"), py::arg("T_W_S"), "Adds a true pose for groundtruth.txt.")
      .def("flush", &io::LogWriter::flush, "Rewrites frames.csv (and groundtruth.txt) atomically.")
      .def("close", &io::LogWriter::close, "flush() and stop; idempotent.")
      .def("__len__", &io::LogWriter::size)
      .def_property_readonly("folder", &io::LogWriter::folder, "the log folder")
      .def(
          "__enter__", [](io::LogWriter& self) -> io::LogWriter& { return self; }, py::return_value_policy::reference)
      .def(
          "__exit__",
          [](io::LogWriter& self, py::handle exc_type, py::handle, py::handle) {
            // On an exception in the block, close quietly so that exception is the one seen.
            if (exc_type.is_none()) {
              self.close();
            } else {
              try {
                self.close();
              } catch (const std::exception&) {
              }
            }
            return false;
          },
          py::arg("exc_type"), py::arg("exc_value"), py::arg("traceback"));
}

void bindMapFile(py::module_& m) {
  py::class_<MapFileGrid> g(m, "MapFileGrid", "One grid of a .vdb file.");
  g.def_readonly("name", &MapFileGrid::name, "'tsdf', 'weight', ...")
      .def_readonly("type", &MapFileGrid::type, "OpenVDB value type, e.g. 'float'")
      .def_readonly("grid_class", &MapFileGrid::grid_class, "e.g. 'level set'")
      .def_readonly("active_voxels", &MapFileGrid::active_voxels, "exact count")
      .def_readonly("leaf_nodes", &MapFileGrid::leaf_nodes, "8^3 leaf nodes")
      .def_readonly("memory_bytes", &MapFileGrid::memory_bytes, "in memory once loaded")
      .def_readonly("voxel_size_m", &MapFileGrid::voxel_size_m, "voxel edge in metres")
      .def_property_readonly(
          "bbox_index", [](const MapFileGrid& x) { return toTuple(x.bbox_index); },
          "((i, j, k) min, (i, j, k) max) of active voxels, or None")
      .def("__repr__", [](py::handle self) { return reprOfProperties(self); });

  py::class_<MapFileInfo> i(m, "MapFileInfo", "What `vdbmap info` shows about a .vdb file.");
  i.def_readonly("path", &MapFileInfo::path, "the file")
      .def_readonly("file_bytes", &MapFileInfo::file_bytes, "size on disk")
      .def_readonly("grids", &MapFileInfo::grids, "list of MapFileGrid")
      .def_property_readonly(
          "metadata",
          [](const MapFileInfo& x) {
            py::dict d;
            for (const auto& [k, v] : x.metadata) d[py::str(k)] = v;
            return d;
          },
          "file metadata as text, {name: value}")
      .def_readonly("has_exact_state", &MapFileInfo::has_exact_state,
                    "the .exact.vdb companion exists and belongs to this map")
      .def_readonly("exact_state_problem", &MapFileInfo::exact_state_problem,
                    "why an existing companion is not usable ('' when it is or is absent)")
      .def_readonly("unit_id", &MapFileInfo::unit_id, "the save's unit id ('' for maps of format 3 and older)")
      .def_readonly("weight_scale", &MapFileInfo::weight_scale,
                    "the exact state's units per ray weight (0 without a usable companion)")
      .def("__repr__", [](py::handle self) { return reprOfProperties(self); });

  m.def("inspect_map_file", &inspectMapFile, py::arg("path"), py::call_guard<py::gil_scoped_release>(),
        "Lists a .vdb file's grids (fully read, so counts are exact) and metadata.");
}

void bindIo(py::module_& m) {
  bindSensor(m);
  bindFrames(m);
  bindFrameSource(m);
  bindReplay(m);
  bindFiles(m);
  bindLogWriter(m);
  bindMapFile(m);
}

const BindRegistration registration(kBindIo, "io", &bindIo);

}  // namespace
}  // namespace vdbmap::python
