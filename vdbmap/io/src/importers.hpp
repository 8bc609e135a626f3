// Private: the readers behind openDataset, one per layout. Each lists frames in place (no
// conversion) and says in FrameSourceContents::description where its intrinsics, depth scale
// and poses came from.
#pragma once

#include "vdbmap/io/frame_source.hpp"

#include <filesystem>

namespace vdbmap::io::detail {

/// Our log format: sensor.json, frames.csv, corrections/, groundtruth.txt.
FrameSourceContents readLog(const std::filesystem::path& folder);

/// Detection: returns the layout of `path` and the folder to read it from (which can be a
/// sub-folder, e.g. RGBD/ of Open3D's test data or the one seq-XX of a 3DMatch scene). Throws
/// std::runtime_error when a layout is recognised but ambiguous (several sequences).
DatasetFormat detectLayout(const std::filesystem::path& path, std::filesystem::path& folder);

FrameSourceContents importSevenScenes(const std::filesystem::path& folder, DatasetFormat as);  // 7-Scenes and 3DMatch
FrameSourceContents importIclNuim(const std::filesystem::path& folder);
FrameSourceContents importRedwood(const std::filesystem::path& folder);
FrameSourceContents importTum(const std::filesystem::path& folder);
FrameSourceContents importReplica(const std::filesystem::path& folder);

}  // namespace vdbmap::io::detail
