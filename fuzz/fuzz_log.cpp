// Fuzz target: a log or dataset folder through io::openDataset (layout auto-detected), then every
// frame and every correction, as `vdbmap integrate` reads them.
//
// The input is a small archive of the folder's files (fuzz/seeds/fuzz_log/ and make_corpus.sh
// write such archives): each file starts with a line "@@ <relative path>" and holds the bytes up to
// the next "\n@@ " or the end of the input, e.g.
//
//   @@ sensor.json
//   {"kind": "depth", "width": 4, ...}
//   @@ frames.csv
//   timestamp,file,tx,ty,tz,qx,qy,qz,qw
//   0.0,d/0.png,0,0,0,0,0,0,1
//   @@ corrections/0.000000.txt
//   ...
//   @@ d/0.png
//   <PNG bytes>
//
// so the fuzzer mutates names as well as contents and reaches the other layouts' importers too.
// Paths are kept inside the scratch folder: a name with "..", an absolute name or characters
// outside [A-Za-z0-9._-/] is skipped, and so is a frame whose listed file lies outside the folder
// (frames.csv may name absolute files, and /dev/zero is not a parser bug).
#include "fuzz_support.hpp"

#include "vdbmap/io/frame_source.hpp"
#include "vdbmap/io/pose_interpolation.hpp"

#include <algorithm>
#include <memory>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace {

constexpr std::size_t kMaxFiles = 32;
constexpr std::size_t kMaxNameBytes = 100;

// True for a relative path of at most four plain components.
bool safeRelativeName(std::string_view name) {
  if (name.empty() || name.size() > kMaxNameBytes || name.front() == '/') return false;
  for (const char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' ||
                    c == '-' || c == '/';
    if (!ok) return false;
  }
  std::size_t components = 0, start = 0;
  while (start <= name.size()) {
    const std::size_t end = std::min(name.find('/', start), name.size());
    const std::string_view part = name.substr(start, end - start);
    if (part.empty() || part == "." || part == "..") return false;
    ++components;
    start = end + 1;
  }
  return components <= 4;
}

// Unpacks the archive into `dir`; files whose name is unsafe or cannot be created are skipped.
void unpack(std::string_view in, const std::filesystem::path& dir) {
  static constexpr std::string_view kMark = "@@ ";
  std::size_t pos = in.substr(0, kMark.size()) == kMark ? 0 : in.find("\n@@ ");
  if (pos != std::string_view::npos && pos != 0) ++pos;  // past the '\n'
  std::size_t files = 0;
  while (pos != std::string_view::npos && pos < in.size() && files < kMaxFiles) {
    const std::size_t name_begin = pos + kMark.size();
    const std::size_t name_end = std::min(in.find('\n', name_begin), in.size());
    const std::string_view name = in.substr(name_begin, name_end - name_begin);
    const std::size_t body_begin = std::min(name_end + 1, in.size());
    const std::size_t next = in.find("\n@@ ", body_begin);
    const std::size_t body_end = next == std::string_view::npos ? in.size() : next;
    pos = next == std::string_view::npos ? next : next + 1;
    if (!safeRelativeName(name)) continue;
    const std::filesystem::path file = dir / std::string(name);
    std::error_code ec;
    std::filesystem::create_directories(file.parent_path(), ec);
    if (ec || std::filesystem::is_directory(file, ec)) continue;  // e.g. "a" then "a/b"
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(in.data() + body_begin, std::streamsize(body_end - body_begin));
    ++files;
  }
}

// True when `file` lies lexically inside `dir` (which holds no symbolic links).
bool inside(const std::filesystem::path& file, const std::filesystem::path& dir) {
  const std::string f = file.lexically_normal().string();
  const std::string d = dir.lexically_normal().string() + "/";
  return f.compare(0, d.size(), d) == 0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace vdbmap;
  const std::filesystem::path dir = fuzz::freshScratchDir() / "log";
  std::filesystem::create_directories(dir);
  unpack(std::string_view(reinterpret_cast<const char*>(data), size), dir);
  fuzz::expectRefusalOrSuccess([&] {
    const std::unique_ptr<io::FrameSource> source = io::openDataset(dir);
    // Every frame once per distinct file (frames.csv may list one file a thousand times; reading
    // it again tests nothing new and only slows the fuzzer down).
    std::set<std::string> seen;
    for (std::size_t i = 0; i < source->size(); ++i) {
      const io::FrameRecord& r = source->record(i);
      if (!inside(r.file, dir)) continue;
      if (r.problem.empty() && !seen.insert(r.file.lexically_normal().string()).second) continue;
      fuzz::expectRefusalOrSuccess([&] { source->load(i); });
    }
    // Every correction, applied as log replay applies it (vdbmap/io/src/log_replay.cpp).
    for (const io::CorrectionEvent& e : source->corrections()) {
      std::vector<io::StampedPose> odometry;
      for (std::size_t j = 0; j <= e.event_frame; ++j) {
        const io::FrameRecord& r = source->record(j);
        if (r.problem.empty()) odometry.push_back({r.timestamp_s, r.T_W_S});
      }
      fuzz::expectRefusalOrSuccess([&] { io::applyCorrection(odometry, e.poses); });
    }
  });
  return 0;
}
